"""The material trainer pays for each fit once: one shared set of features per recording,
the ensemble's members reused from the other candidates' folds, folds in parallel, trials
stopped as soon as they cannot win; its new candidates (RBF SVM, boosted trees) export to
ONNX like the others; its progress goes to stderr only."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from fingertip.models.vibration.augment import AugmentConfig
from fingertip.models.vibration.bank import build_bank, candidate_windows, with_copies
from fingertip.models.vibration.candidates import CANDIDATES, TIE, candidates
from fingertip.models.vibration.classify import load_folder, stratified_folds
from fingertip.models.vibration.cross_validation import (
    TRIAL_ROUND,
    FitMemo,
    fold_rounds,
    cross_validate,
    cross_validate_against,
    training_rows,
)
from fingertip.models.vibration.progress import Progress
from fingertip.models.vibration.scores import (
    Answers,
    accuracy_by_time,
    likely_at_most,
    mean_accuracy,
)
from fingertip.models.vibration.setup import choose_setup
from fingertip.models.vibration.spectral import to_onnx, train_boost, train_svm
from fingertip.models.nets.mlp import OnnxModel
from tests.models.vibration.band_noise import write_band_noise

RATE = 8000


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """Three classes of noise in overlapping bands (the middle one close to both), 1 s."""
    return write_band_noise(tmp_path_factory.mktemp("speed"),
                            {"low": (200, 900), "mid": (600, 1600), "high": (1100, 3000)},
                            per_class=8, rate=RATE, seed=5)


@pytest.fixture(scope="module")
def setup_ds(folder):
    ds = load_folder(folder)
    return ds, choose_setup(ds)


def _inputs(ws):
    return [w.inputs for w in ws]


def test_the_shared_features_equal_each_candidates_own(setup_ds):
    """Every candidate's columns of the one spectrum per recording equal the features its
    own pipeline computes (what it sees at run time), training and answered windows; the
    CNN's spectrogram windows too."""
    ds, setup = setup_ds
    cands = candidates(setup, CANDIDATES)
    bank = build_bank(setup, ds, cands, "clean")
    for cand in cands:
        shared, own = bank.view(cand), candidate_windows(cand, ds)
        for a, b in ((shared.train, own.train), (shared.test, own.test)):
            for x, y in zip(_inputs(a), _inputs(b), strict=True):
                assert x.shape == y.shape, cand.name
                # float32 band matrices of different widths: equal to rounding
                np.testing.assert_allclose(x, y, atol=2e-3, err_msg=cand.name)
        for x, y in zip(shared.test, own.test, strict=True):
            np.testing.assert_array_equal(x.t_end, y.t_end)
            np.testing.assert_array_equal(x.growing, y.growing)


def test_the_augmented_copies_windows_equal_each_candidates_own(setup_ds):
    """The shared features of the augmented copies (only their windows from the start
    computed) equal each candidate's own pipeline's windows of the same copies, every
    window computed and those from the start kept."""
    ds, setup = setup_ds
    cands = candidates(setup, ("baseline", "mlp", "svm"))
    aug = AugmentConfig()
    bank = with_copies(build_bank(setup, ds, cands, "clean"), ds, aug, 3, cands)
    for cand in cands:
        shared, own = bank.view(cand), candidate_windows(cand, ds, aug, seed=3)
        assert sum(len(w) for w in shared.train) > sum(len(w) for w in
                                                       build_bank(setup, ds, cands, "c")
                                                       .view(cand).train)
        for x, y in zip(shared.train, own.train, strict=True):
            assert x.inputs.shape == y.inputs.shape, cand.name
            np.testing.assert_allclose(x.inputs, y.inputs, atol=2e-3, err_msg=cand.name)
            np.testing.assert_array_equal(x.t_end, y.t_end)


def test_the_ensembles_members_are_reused_and_equal_refits(setup_ds):
    """Cross-validating the ensemble after its members' candidates reuses their fold
    models (no new fit but the second MLP's) and answers exactly as refitting them all."""
    ds, setup = setup_ds
    labels = ds.labels
    folds = stratified_folds(labels, 3, 0)
    cands = {c.name: c for c in candidates(setup, ("baseline", "linear", "mlp", "ensemble"),
                                           epochs=30)}
    bank = build_bank(setup, ds, list(cands.values()), "clean")
    memo = FitMemo()
    for name in ("baseline", "linear", "mlp"):
        cross_validate(cands[name], bank.view(cands[name]), labels, folds, ds.classes, 0,
                       memo=memo)
    before = len(memo)
    reused = cross_validate(cands["ensemble"], bank.view(cands["ensemble"]), labels, folds,
                            ds.classes, 0, memo=memo)
    assert len(memo) == before + len(folds)  # only the second MLP of each fold is new
    fresh_c = {c.name: c for c in candidates(setup, ("ensemble",), epochs=30)}["ensemble"]
    fresh = cross_validate(fresh_c, bank.view(fresh_c), labels, folds, ds.classes, 0,
                           memo=FitMemo())
    assert reused.keys() == fresh.keys()
    for i in reused:
        np.testing.assert_array_equal(reused[i].probs, fresh[i].probs)
        np.testing.assert_array_equal(reused[i].dist, fresh[i].dist)


def test_folds_in_parallel_give_the_same_answers(setup_ds):
    ds, setup = setup_ds
    labels = ds.labels
    folds = stratified_folds(labels, 4, 0)
    got = []
    for jobs in (1, 2):
        cand = candidates(setup, ("linear",))[0]
        bank = build_bank(setup, ds, [cand], "clean")
        got.append(cross_validate(cand, bank.view(cand), labels, folds, ds.classes, 0,
                                  jobs=jobs))
    assert got[0].keys() == got[1].keys()
    for i in got[0]:
        np.testing.assert_array_equal(got[0][i].probs, got[1][i].probs)


@pytest.fixture(scope="module")
def hard(tmp_path_factory):
    """Three classes of noise in nearly the same band: a linear model errs on some."""
    ds = load_folder(write_band_noise(tmp_path_factory.mktemp("hard"),
                                      {"a": (500, 1400), "b": (540, 1450), "c": (580, 1500)},
                                      per_class=8, rate=RATE, seconds=0.5, seed=7))
    return ds, choose_setup(ds)


def test_a_trial_stopped_early_decides_as_the_full_trial(hard):
    """A trial that must reach more than it can stops after its first round of folds,
    and its decision (not adopted) is the one the whole cross-validation gives."""
    ds, setup = hard
    labels = ds.labels
    folds = stratified_folds(labels, 4, 0)
    cand = candidates(setup, ("linear",))[0]
    bank = build_bank(setup, ds, [cand], "clean")
    cw = bank.view(cand)
    full = cross_validate(cand, cw, labels, folds, ds.classes, 0)
    acc = mean_accuracy(accuracy_by_time(full, labels))
    assert acc < 1.0  # the set is hard enough for the bound to bite
    # "clean": a perfect plain model, so every recording not yet answered counts right
    perfect = {i: a for i, a in full.items()}
    need = acc + 0.5 * (1.0 - acc) + 1e-9
    for jobs in (1, 2):
        trial = cross_validate_against(candidates(setup, ("linear",))[0], cw, labels, folds,
                                       ds.classes, 0, perfect, need, jobs=jobs)
        if trial.table is None:  # stopped early
            assert trial.folds_run < len(folds)
            assert trial.bound < need
        adopted_early = trial.table is not None and trial.accuracy >= need
        assert adopted_early is (acc >= need) is False
    # with the bound triggering from the first round of folds on, the first check stops it
    stopped = cross_validate_against(candidates(setup, ("linear",))[0], cw, labels, folds,
                                     ds.classes, 0, perfect, 1.0 + 1e-9)
    assert stopped.table is None and stopped.folds_run == TRIAL_ROUND and stopped.sure


def test_an_ensemble_trial_stops_after_its_first_round_of_folds(hard):
    """The ensemble's members are fitted a round of folds at a time, so its trial stops
    like any candidate's (it used to fit every fold's members before the first check);
    a round is as many folds as make TRIAL_ROUND new fits: one fold of a trial, whose
    four members are all new, two where only the second MLP is (the others' folds are
    remembered from their own cross-validations), three of a plain candidate whose first
    fold is remembered."""
    ds, setup = hard
    labels = ds.labels
    folds = stratified_folds(labels, 4, 0)
    trains = [np.setdiff1d(np.concatenate(folds), te) for te in folds]
    cands = candidates(setup, ("baseline", "linear", "mlp", "ensemble"), epochs=20)
    ens = cands[-1]
    bank = build_bank(setup, ds, cands, "clean")
    full = cross_validate(ens, bank.view(ens), labels, folds, ds.classes, 0)
    memo = FitMemo()
    assert fold_rounds(ens, bank.view(ens), trains, 0, memo, True) == [[0], [1], [2], [3]]
    assert fold_rounds(ens, bank.view(ens), trains, 0, memo, False) == [[0, 1, 2, 3]]
    stopped = cross_validate_against(ens, bank.view(ens), labels, folds, ds.classes, 0,
                                     full, 1.0 + 1e-9, jobs=2, memo=memo)
    assert stopped.table is None and stopped.folds_run == 1
    assert len(memo) == len(ens.members)  # the other folds never fitted
    memo = FitMemo()
    lin = cands[1]
    assert fold_rounds(lin, bank.view(lin), trains, 0, memo, True) == [[0, 1], [2, 3]]
    for c in cands[:3]:
        cross_validate(c, bank.view(c), labels, folds, ds.classes, 0, memo=memo)
    assert fold_rounds(ens, bank.view(ens), trains, 0, memo, True) == [[0, 1], [2, 3]]
    memo = FitMemo()
    memo.put(memo.key("linear", "clean", trains[0], 0), object(), 0.0)
    assert fold_rounds(lin, bank.view(lin), trains, 0, memo, True) == [[0, 1, 2], [3]]


def _answers(right: list[bool], k: int = 3) -> dict[int, Answers]:
    """Recording i of class 0 answered (at 0.25, 0.5, 1 s) right or as class 1."""
    t = np.array([0.25, 0.5, 1.0])
    out = {}
    for i, ok in enumerate(right):
        p = np.full((3, k), 0.1)
        p[:, 0 if ok else 1] = 0.8
        out[i] = Answers(p, p, t, i % 5)
    return out


def test_the_confidence_bound_stops_a_trial_only_when_it_is_clearly_behind():
    """A trial that has answered 400 of 1,000 recordings 3 points worse than the plain
    model (on the same ones) is stopped: even at 3 standard errors the others cannot
    bring it within the tie. One only 1 point worse, or one that has answered too few,
    is not; with every answer the same, nothing is stopped."""
    rng = np.random.default_rng(0)
    labels = np.zeros(1000, np.intp)
    clean_right = rng.uniform(size=1000) < 0.85
    clean = _answers(list(clean_right))
    base = mean_accuracy(accuracy_by_time(clean, labels))

    def worse_by(points: float, n: int) -> dict[int, Answers]:
        right = clean_right[:n].copy()
        flip = rng.choice(np.flatnonzero(right), int(points / 100 * n), replace=False)
        right[flip] = False
        return {i: a for i, a in _answers(list(right)).items()}

    need = base - TIE
    assert likely_at_most(worse_by(3, 400), clean, labels) < need
    assert likely_at_most(worse_by(1, 400), clean, labels) > need
    assert likely_at_most(worse_by(10, 20), clean, labels) == np.inf  # too few to judge
    same = {i: clean[i] for i in range(400)}
    assert likely_at_most(same, clean, labels) == pytest.approx(base)


def test_the_paired_bound_takes_answers_on_other_windows():
    """A candidate on windows of its own (the CNN's) may stop a frame short of a decision
    time the other reached: the paired difference counts the times both reached."""
    labels = np.zeros(60, np.intp)
    right = np.array([[0.8, 0.1, 0.1]] * 3)
    wrong = np.array([[0.1, 0.8, 0.1]] * 3)
    every = {i: Answers(right, right, np.array([0.25, 0.5, 1.0]), i % 5) for i in range(60)}
    part = {i: Answers(wrong if i % 4 == 0 else right, wrong if i % 4 == 0 else right,
                       np.array([0.25, 0.5, 0.9]), i % 5) for i in range(40)}
    bound = likely_at_most(part, every, labels, times=(0.25, 0.5, 1.0, None))
    assert np.isfinite(bound) and bound < 1.0


@pytest.mark.parametrize("train", [train_svm, train_boost])
def test_svm_and_boosted_trees_export_to_onnx_matching_float64(setup_ds, train, tmp_path):
    ds, setup = setup_ds
    cand = candidates(setup, ("svm",))[0]
    bank = build_bank(setup, ds, [cand], "clean")
    labels = ds.labels
    x, y, g = training_rows(bank.view(cand), labels, np.arange(len(labels)),
                            len(ds.classes))
    m = train(x, y, g, ds.classes, 0)
    for t in (1.0, 1.7):
        got = OnnxModel(to_onnx(m, tmp_path / f"m{t}.onnx", temperature=t))(
            x.astype(np.float32))
        p = np.log(np.clip(m.forward(x), 1e-12, None)) / t
        want = np.exp(p - p.max(1, keepdims=True))
        want /= want.sum(1, keepdims=True)
        np.testing.assert_allclose(got, want, atol=1e-4)
    assert m.n_params > 0


def test_progress_goes_to_stderr_only(folder, tmp_path):
    """`--json` prints the report, and only it, on stdout; the bars are on stderr (one
    line when a phase starts and one when it ends, stderr not being a terminal)."""
    out = subprocess.run([sys.executable, "-m", "fingertip.cli", "train", "material", str(folder),
                          "--out", str(tmp_path / "m"), "--json", "--folds", "3",
                          "--models", "linear,svm", "--augment", "0"],
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout)  # nothing else on stdout
    assert report["model"] in ("linear", "svm")
    assert "cross-validation: svm" in out.stderr
    assert "features (one spectrum per recording)" in out.stderr


def test_progress_line_and_non_tty_lines(capsys):
    with Progress("phase", 3) as p:
        for _ in range(3):
            p.update()
    err = capsys.readouterr().err
    assert err.startswith("phase: 3 steps ...\n") and "phase: 3/3 in" in err


def test_features_in_worker_processes_are_the_same(setup_ds, monkeypatch):
    """The shared features and the augmented copies' windows, computed in chunks of
    recordings on two workers, equal those computed in this process."""
    from fingertip.models.vibration import bank as bank_mod
    from fingertip.models.vibration.augment import AugmentConfig
    from fingertip.models.vibration.bank import with_copies

    monkeypatch.setattr(bank_mod, "CHUNK", 5)
    ds, setup = setup_ds
    cands = candidates(setup, ("baseline", "ensemble", "cnn"))
    one, two = (build_bank(setup, ds, cands, "clean", jobs=j) for j in (1, 2))
    more = [with_copies(b, ds, AugmentConfig(), 3, cands, jobs=j)
            for b, j in ((one, 1), (two, 2))]
    for a, b in ((one.train, two.train), (one.test, two.test),
                 (more[0].train, more[1].train), (one.own["cnn"].test, two.own["cnn"].test),
                 (more[0].own["cnn"].train, more[1].own["cnn"].train)):
        assert len(a) == len(b) == len(ds.items)
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x.inputs, y.inputs)
            np.testing.assert_array_equal(x.t_end, y.t_end)
