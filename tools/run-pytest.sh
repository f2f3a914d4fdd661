#!/usr/bin/env bash
# make test-python: pytest in two passes that run at the same time.
#
#   tools/run-pytest.sh PYTHON WORKERS [PYTEST_ARGS...]
#
# - The tests marked `realtime` assert on wall-clock time (pacing, latency, reconnects). They
#   run one at a time, at normal priority. They are mostly waiting (about a third of a core
#   over their 4 minutes), so they need no core of their own, only to be scheduled when due.
# - The others spread over WORKERS pytest-xdist processes under `nice -n 5` (PYTEST_NICE):
#   the scheduler gives the realtime pass the CPU first, and the workers the rest. Measured
#   here on 2 cores: at equal priority, the realtime tests beside three workers and two busy
#   loops fail (simavr falls seconds behind its pace); under nice 5 they pass beside two busy
#   loops, and the workers still get two thirds of a core there (nice 10: a quarter).
# The realtime pass's output goes to build/pytest-realtime.log and is printed after the
# parallel pass, so the two do not interleave. pytest exits 5 when it collected nothing:
# when neither pass ran a test, that must fail, never pass as "green"; one pass may be empty
# (PYTEST_ARGS=tests/protocol has no realtime test).
set -u
py=$1 workers=$2
shift 2
mkdir -p build
log=build/pytest-realtime.log

# The realtime pass writes no cache: two sessions ending together would overwrite each
# other's `lastfailed`.
"$py" -m pytest -n 0 -m realtime -p no:cacheprovider "$@" >"$log" 2>&1 &
rt=$!
# Stopped (Ctrl-C, a failing CI step): the background pass goes too.
trap 'kill -TERM "$rt" 2>/dev/null' EXIT
echo "run-pytest: the realtime tests run beside this pass (output: $log)"

nice -n "${PYTEST_NICE:-5}" "$py" -m pytest -n "$workers" --dist loadgroup -m "not realtime" "$@"
rc1=$?
wait "$rt"
rc2=$?
trap - EXIT
echo "--- the realtime pass (run beside the one above) ---"
cat "$log"

if [ "$rc1" -eq 5 ] && [ "$rc2" -eq 5 ]; then
    echo "pytest collected no tests: failing" >&2
    exit 1
fi
for rc in "$rc1" "$rc2"; do
    if [ "$rc" -ne 0 ] && [ "$rc" -ne 5 ]; then exit "$rc"; fi
done
exit 0
