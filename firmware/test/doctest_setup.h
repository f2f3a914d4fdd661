// doctest set-up shared by the native suites. `make test-native` uses doctest's own main;
// PlatformIO's test runner (it defines PIO_UNIT_TESTING) needs a main that reports successful
// test cases and leaves the verdict to the runner, as its doctest documentation requires.
// Include this first, exactly once per test program.
#ifndef FINGERTIP_TEST_DOCTEST_SETUP_H
#define FINGERTIP_TEST_DOCTEST_SETUP_H

#ifdef PIO_UNIT_TESTING
#define DOCTEST_CONFIG_IMPLEMENT
#else
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#endif

// Debian's doctest-dev installs <doctest/doctest.h>; PlatformIO's package gives <doctest.h>.
#if __has_include(<doctest/doctest.h>)
#include <doctest/doctest.h>
#else
#include <doctest.h>
#endif

#ifdef PIO_UNIT_TESTING
int main(int argc, char** argv) {
  doctest::Context context;
  context.setOption("success", true);      // PlatformIO parses every test case
  context.setOption("no-exitcode", true);  // and decides the verdict itself
  context.applyCommandLine(argc, argv);
  return context.run();
}
#endif

#endif  // FINGERTIP_TEST_DOCTEST_SETUP_H
