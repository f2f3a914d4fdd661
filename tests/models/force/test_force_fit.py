"""Force calibration: data checks, held-out split, affine/polynomial/MLP fits, ONNX parity.

Data: the paper's sweep simulated on virtual units (fingertip.sim.physics), tared like the
device does. Measured on these units (grid hold-out, one sweep of training data, 300 MLP
epochs): affine 0.24-0.33 N, poly3 0.17-0.22 N, mlp16x16 0.14-0.19 N; the next sweep of the
same unit 0.13-0.16 N. The tests hold the chosen model to 0.2 N (the issue's target; the
paper's MSE of 0.15 N^2 is about 0.39 N).
"""
from __future__ import annotations

import numpy as np
import pytest

from fingertip.models.force.calibrate import (
    INT24_MAX,
    INT24_MIN,
    MAX_CONDITION,
    CalibrationError,
    DatasetFormatError,
    DeadChannelError,
    IllConditionedError,
    MixedUnitsError,
    NonFiniteError,
    SaturationError,
    SingleDirectionError,
    TooFewRowsError,
    check_dataset,
    choose,
    design_condition,
    expand_models,
    extreme_inputs,
    fit_affine,
    fit_calibration,
    fit_mlp,
    fit_poly,
    float32_error,
    from_arrays,
    load_dataset,
    rmse,
    split_groups,
    split_holdout,
)
from fingertip.sim.physics import Realism, VirtualStrainSensor
from fingertip.sim.device.calibration_rig import calibration_sweep

RMSE_TARGET_N = 0.2


def sweep_data(unit: int, sweeps: int = 1, **kw):
    """``sweeps`` consecutive sweeps of one unit, tared first (one session), as data.

    The ideal sensor (``Realism.ideal()``): these tests check the fitting, and their error
    targets are set for it; the realistic figures are tests/bench/bench_realism.py's."""
    sensor = VirtualStrainSensor(unit, realism=Realism.ideal())
    tare = np.rint(sensor.counts_batch(np.zeros((16, 2)), 0.0, np.arange(1, 17) / 80)
                   .mean(axis=0))
    out, t0 = [], 1_000_000
    for k in range(sweeps):
        sw = calibration_sweep(sensor, seed=1000 * unit + k, t0_us=t0, **kw)
        t0 = int(sw.t_us[-1]) + 1_000_000
        out.append(from_arrays(sw.counts - tare, sw.fx, sw.fy, angle_deg=sw.angle_deg,
                               height_mm=sw.height_mm, trial=sw.trial,
                               phase=np.where(sw.loading, "loading", "unloading")))
    return out


@pytest.fixture(scope="module")
def unit2():
    return sweep_data(2, sweeps=2)


def _arrays(d):
    return dict(angle_deg=d.angle_deg, height_mm=d.height_mm, trial=d.trial)


# --- fits ---------------------------------------------------------------------------------

def test_affine_recovers_a_linear_map_exactly():
    rng = np.random.default_rng(3)
    x = rng.normal(0, 2e5, (500, 4)) + rng.normal(0, 1e4, 4)
    w = rng.normal(0, 1e-5, (4, 2))
    b = np.array([0.3, -0.2])
    f = x @ w + b
    m = fit_affine(x, f)
    np.testing.assert_allclose(m.predict(x), f, rtol=0, atol=1e-9)
    # Back in raw counts: weights = coef / std, offset = intercept - mean @ weights.
    np.testing.assert_allclose(m.coef / m.x_std[:, None], w, rtol=1e-9)
    np.testing.assert_allclose(m.intercept - m.x_mean @ (m.coef / m.x_std[:, None]), b,
                               rtol=1e-9)
    assert m.condition < 10


def test_physical_units_are_well_enough_conditioned(unit2):
    cond, _ = design_condition(unit2[0].counts)
    # Opposite gauges are correlated near -0.99, yet far from the refusal threshold.
    assert 50 < cond < MAX_CONDITION / 100
    s = check_dataset(unit2[0])
    assert s["rows"] == 2640 and min(s["response_r2"]) > 0.9


def test_poly_and_mlp_beat_affine_on_held_out_cells(unit2):
    d = unit2[0]
    tr, te, how = split_holdout(d)
    a, b = d.take(tr), d.take(te)
    g, mode = split_groups(a)
    assert mode == "grid" and "cells" in how
    aff = rmse(fit_affine(a.counts, a.force).predict(b.counts), b.force)
    p3 = fit_poly(a.counts, a.force, 3, groups=g)
    mlp = fit_mlp(a.counts, a.force, (16, 16), epochs=300)
    assert rmse(p3.predict(b.counts), b.force) < aff
    assert rmse(mlp.predict(b.counts), b.force) < aff
    assert p3.condition < 1e4   # whitened monomials: float32-friendly


def test_holdout_keeps_whole_cells_apart(unit2):
    both = unit2[0]
    d = from_arrays(np.concatenate([both.counts, unit2[1].counts]),
                    *np.concatenate([both.force, unit2[1].force]).T,
                    angle_deg=np.concatenate([both.angle_deg, unit2[1].angle_deg]),
                    height_mm=np.concatenate([both.height_mm, unit2[1].height_mm]),
                    trial=np.concatenate([both.trial, unit2[1].trial + 1000]))
    tr, te, _ = split_holdout(d)
    assert 0.2 < len(te) / len(d) < 0.3
    cells = {(a, h) for a, h in zip(d.angle_deg[te], d.height_mm[te], strict=True)}
    train_cells = {(a, h) for a, h in zip(d.angle_deg[tr], d.height_mm[tr], strict=True)}
    assert not cells & train_cells                       # both sweeps of a cell together
    assert set(d.angle_deg[te]) == set(d.angle_deg)      # every angle and height tested
    assert set(d.height_mm[te]) == set(d.height_mm)
    # Without angle/height: whole trials; without trials: blocks of consecutive rows.
    t = from_arrays(d.counts, *d.force.T, trial=d.trial)
    tr, te, how = split_holdout(t)
    assert how.startswith("trial") and not set(t.trial[tr]) & set(t.trial[te])
    bl = from_arrays(d.counts, *d.force.T)
    tr, te, how = split_holdout(bl)
    assert how.startswith("blocks") and len(te) and len(tr)


def test_chosen_model_meets_the_error_target(unit2, tmp_path):
    from fingertip.models.force.runtime import ForceModel

    rep = fit_calibration(unit2[0], tmp_path, models="affine,poly3,mlp16x16", epochs=300,
                          single_calls=300)
    names = [m.name for m in rep.models]
    assert names == ["affine", "poly3", "mlp16x16"]
    c = rep.chosen_result
    assert c.rmse_n <= RMSE_TARGET_N, rep.table()
    assert c.rmse_n <= 1.1 * min(m.rmse_n for m in rep.models) + 1e-9
    assert c.mse_n2 == pytest.approx(c.rmse_n ** 2, rel=1e-3)
    assert set(c.by_height) == {str(h) for h in range(6)}
    assert set(c.by_angle) == {str(a) for a in range(-50, 51, 10)}
    assert set(c.by_phase) == {"loading", "unloading"}
    for f in ("force.onnx", "calibration.json", "calibration.md", "speed_vs_error.png",
              "force_affine.onnx", "force_poly3.onnx", "force_mlp16x16.onnx"):
        assert (tmp_path / f).stat().st_size > 0, f
    assert "| model |" in (tmp_path / "calibration.md").read_text()
    # The exported model on the next sweep of the same unit (another session).
    fm = ForceModel(tmp_path / "force.onnx")
    assert fm.kind == c.name and fm.rmse_n == pytest.approx(c.rmse_n)
    assert rmse(fm.estimate(unit2[1].counts), unit2[1].force) <= RMSE_TARGET_N


def test_choice_rule():
    from fingertip.models.force.calibrate import ModelResult

    def r(name, err, lat):
        return ModelResult(name, "x", 1, err, err ** 2, err, err, err, lat, lat / 100, 0, 0,
                           0, "")

    rs = [r("a", 0.30, 5.0), r("b", 0.150, 8.0), r("c", 0.140, 9.0), r("d", 0.160, 6.0)]
    assert choose(rs, 10)[0] == "b"          # <= 0.154 N: b and c; b is faster
    assert choose(rs, 0)[0] == "c"
    assert choose(rs, 100)[0] == "d"         # <= 0.28 N: a is still out, d is fastest
    assert choose(rs, 115)[0] == "a"
    rs.append(r("e", 0.145, 8.2))            # within 5 % of b's latency: the better wins
    assert choose(rs, 10)[0] == "e"


def test_model_names():
    assert expand_models("affine,poly,mlp") == ["affine", "poly2", "poly3", "mlp8",
                                                "mlp16x16", "mlp32x32"]
    assert expand_models("poly4, mlp64x64") == ["poly4", "mlp64x64"]
    for bad in ("svm", "poly9", "mlpx", "mlp0", ""):
        with pytest.raises(ValueError):
            expand_models(bad)


# --- ONNX: float32 against the float64 reference --------------------------------------

@pytest.mark.parametrize("name", ["affine", "poly2", "poly3", "mlp8", "mlp16x16"])
def test_onnx_float32_matches_float64(unit2, tmp_path, name):
    """Tolerances: 2e-4 N on measured counts (the HX711 noise alone is ~3e-4 N), and 1e-3
    of max(|F|, 1 N) at the 24-bit limits (measured: below 6e-5 N and 2e-4)."""
    d = unit2[0]
    if name == "affine":
        m = fit_affine(d.counts, d.force)
    elif name.startswith("poly"):
        m = fit_poly(d.counts, d.force, int(name[4:]))
    else:
        m = fit_mlp(d.counts, d.force, (8,) if name == "mlp8" else (16, 16), epochs=100)
    path = m.to_onnx(tmp_path / f"{name}.onnx", {"model": name})
    in_range, extreme = float32_error(path, m, np.concatenate([d.counts, unit2[1].counts]))
    assert in_range < 2e-4, in_range
    assert extreme < 1e-3, extreme
    assert len(extreme_inputs()) == 81 + 200
    assert extreme_inputs().min() == INT24_MIN and extreme_inputs().max() == INT24_MAX


# --- data that cannot determine the model -----------------------------------------------

def test_single_angle_is_refused():
    d = sweep_data(1, angles_deg=(20,), heights_mm=(0, 2, 4))[0]
    with pytest.raises(SingleDirectionError, match="one direction.*angles in the data: 20"):
        check_dataset(d)


def test_dead_channels_are_refused(unit2):
    d = unit2[0]
    c = d.counts.copy()
    c[:, 3] = 1234.0
    with pytest.raises(DeadChannelError, match="channel 3 is constant"):
        check_dataset(from_arrays(c, *d.force.T, **_arrays(d)))
    c[:, 3] = np.random.default_rng(0).normal(0, 45, len(c)).round()   # noise only
    with pytest.raises(DeadChannelError, match="channel 3 does not respond"):
        check_dataset(from_arrays(c, *d.force.T, **_arrays(d)))
    tmask = np.full(len(c), 0b0100)
    with pytest.raises(DeadChannelError, match="channel 2 timed out in 2640 of 2640"):
        from_arrays(d.counts, *d.force.T, timeout_mask=tmask)
    tmask[:2500] = 0    # a few timeouts: rows dropped and counted, not refused
    ok = from_arrays(d.counts, *d.force.T, timeout_mask=tmask)
    assert len(ok) == 2500 and ok.dropped["timeout"] == 140


def test_identical_channels_are_refused(unit2):
    d = unit2[0]
    c = d.counts.copy()
    c[:, 1] = c[:, 0]
    with pytest.raises(IllConditionedError, match=r"channels 0, 1 are \(nearly\) a linear"):
        check_dataset(from_arrays(c, *d.force.T, **_arrays(d)))
    with pytest.raises(IllConditionedError, match="condition number"):
        fit_affine(c, d.force)
    c[:, 1] = 2 * c[:, 2] + 5   # an exact combination is as bad
    with pytest.raises(IllConditionedError):
        check_dataset(from_arrays(c, *d.force.T, **_arrays(d)))


def test_non_finite_saturated_and_short_data(unit2):
    d = unit2[0]
    c = d.counts.copy()
    c[7, 2] = np.nan
    with pytest.raises(NonFiniteError, match="1 row.*channel.*\\[2\\].*row 7"):
        from_arrays(c, *d.force.T)
    f = d.force.copy()
    f[9, 0] = np.inf
    with pytest.raises(NonFiniteError, match="reference forces"):
        from_arrays(d.counts, *f.T)
    c = d.counts.copy()
    c[:20, 0] = INT24_MAX
    c[20:30, 1] = INT24_MIN
    smask = np.zeros(len(c), np.int64)
    smask[30:35] = 1
    ok = from_arrays(c, *d.force.T, saturation_mask=smask)
    assert ok.dropped == {"timeout": 0, "saturated": 35} and len(ok) == len(c) - 35
    assert any("35 saturated" in w for w in ok.warnings)
    c[:200, 3] = INT24_MAX
    with pytest.raises(SaturationError, match="200 of 2640 rows"):
        from_arrays(c, *d.force.T)
    with pytest.raises(TooFewRowsError, match="30 usable rows"):
        check_dataset(from_arrays(d.counts[:30], *d.force[:30].T))
    with pytest.raises(TooFewRowsError):
        from_arrays(np.zeros((0, 4)), [], [])
    with pytest.raises(DatasetFormatError, match="shape"):
        from_arrays(np.zeros((10, 3)), np.zeros(10), np.zeros(10))
    assert issubclass(SaturationError, CalibrationError)
    assert len({e.code for e in (NonFiniteError, SaturationError, TooFewRowsError,
                                 DeadChannelError, SingleDirectionError, IllConditionedError,
                                 MixedUnitsError, DatasetFormatError)}) == 8


def test_untared_data_gives_a_warning(unit2):
    d = unit2[0]
    raw = from_arrays(d.counts + np.array([3e5, -2e5, 1e5, 4e5]), *d.force.T, **_arrays(d))
    check_dataset(raw)
    assert any("untared" in w for w in raw.warnings)
    check_dataset(d)
    assert not any("untared" in w for w in d.warnings)


# --- files --------------------------------------------------------------------------------

def test_reads_the_sim_dataset_and_plain_csvs(tmp_path, unit2):
    dataset = pytest.importorskip("fingertip.sim.dataset")
    out = tmp_path / "ds"
    dataset.write_calibration(out, units=2, seed=5)
    with pytest.raises(MixedUnitsError, match="units 5, 6.*--unit 5"):
        load_dataset(out)
    d = load_dataset(out, unit=6)
    assert len(d) == 2640 and d.unit == "6" and d.sources == ["unit_5.csv", "unit_6.csv"]
    assert d.has_grid and set(d.phase) == {"loading", "unloading"} and d.trial.min() >= 0
    one = load_dataset(out / "unit_5.csv")
    assert one.unit == "5" and len(one) == 2640 and check_dataset(one)["rows"] == 2640
    with pytest.raises(MixedUnitsError, match="no rows of unit 9"):
        load_dataset(out, unit=9)
    # Any CSV with c0..c3, fx, fy (columns in any order, extra columns ignored).
    plain = tmp_path / "plain.csv"
    src = unit2[0]
    rows = ["note,fy,c3,c2,c1,c0,fx"] + [
        f"x,{float(f[1])!r},{c[3]:.0f},{c[2]:.0f},{c[1]:.0f},{c[0]:.0f},{float(f[0])!r}"
        for c, f in zip(src.counts, src.force, strict=True)]
    plain.write_text("\n".join(rows) + "\n")
    p = load_dataset(plain)
    np.testing.assert_array_equal(p.counts, src.counts)
    np.testing.assert_array_equal(p.force, src.force)
    assert not p.has_grid and split_groups(p)[1] == "blocks"
    (tmp_path / "bad.csv").write_text("a,b\n1,2\n")
    with pytest.raises(DatasetFormatError, match="needs columns c0..c3"):
        load_dataset(tmp_path / "bad.csv")
    with pytest.raises(DatasetFormatError, match="no such file"):
        load_dataset(tmp_path / "missing")
    (tmp_path / "short.csv").write_text("c0,c1,c2,c3,fx,fy\n1,2,3\n")
    with pytest.raises(DatasetFormatError, match="line 2"):
        load_dataset(tmp_path / "short.csv")


def test_non_finite_rows_in_a_file_are_located(tmp_path):
    rows = ["c0,c1,c2,c3,fx,fy"] + [f"{i},{-i},{2 * i},{i % 7},{i / 100},{i / 50}"
                                    for i in range(60)]
    rows[12] = "5,6,,8,0.1,0.2"
    (tmp_path / "a.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(NonFiniteError, match="a.csv: 1 row.*line 13"):
        load_dataset(tmp_path)


class _LoadedMachine:
    """A clock and onnxruntime sessions on a machine whose load comes in stretches: every
    call costs the same work, but takes three times longer while the machine is busy."""

    def __init__(self, stretch_ns: int):
        self.now = 0
        self.stretch_ns = stretch_ns

    def perf_counter_ns(self) -> int:
        return self.now

    def session(self, path):
        from types import SimpleNamespace
        machine = self

        class Session:
            def get_inputs(self):
                return [SimpleNamespace(name="x")]

            def run(self, _outputs, feed):
                busy = (machine.now // machine.stretch_ns) % 2 == 0
                machine.now += 10_000 * len(feed["x"]) * (3 if busy else 1)

        return Session()


@pytest.mark.parametrize("stretch_ms", [1, 3, 7, 20])
def test_equal_models_time_equal_on_a_machine_with_changing_load(monkeypatch, stretch_ms):
    # Two models doing the same work must not come out one faster than the other because
    # the machine was busier while one of them was timed: that decided the calibration's
    # choice between affine and mlp16x16 on a busy machine (8 % apart).
    from types import SimpleNamespace

    from fingertip.models.force.calibration import evaluate
    machine = _LoadedMachine(stretch_ms * 1_000_000)
    monkeypatch.setattr(evaluate, "open_session", machine.session)
    monkeypatch.setattr(evaluate, "time", SimpleNamespace(perf_counter_ns=machine.perf_counter_ns))
    lat = evaluate.measure_latency({"a": "a.onnx", "b": "b.onnx"}, np.zeros((5, 4)),
                                   batch=10)
    (a1, ab), (b1, bb) = lat["a"], lat["b"]
    assert max(a1, b1) / min(a1, b1) < 1.05, lat
    assert max(ab, bb) / min(ab, bb) < 1.05, lat
