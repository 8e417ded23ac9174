"""The command line under bad input and interruption (issue 17): one case per finding.

Every bad input exits 2 with one line on stderr that names the offending option,
column or value, and writes nothing; an interrupted command exits 130 and leaves
existing files as they were.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from thermogym.cli import main


def _digest(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def _one_error_line(capsys, *needles: str) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err and "error" in lines[0], err
    for n in needles:
        assert n in lines[0], (n, lines[0])
    return lines[0]


@pytest.fixture(scope="module")
def strut_csv(tmp_path_factory) -> Path:
    """A short strut step test (73 samples) written by the rig."""
    folder = tmp_path_factory.mktemp("strut")
    assert (
        main(["experiment", "strut", "steps", "--out", str(folder), "--option", "feed_rates=[20]"])
        == 0
    )
    return folder / "strut-step-20.csv"


@pytest.fixture
def axt_csv(tmp_path) -> Path:
    p = tmp_path / "ax.csv"
    t = np.arange(60.0)
    rows = "\n".join(f"{x:g},{1.0 if x < 30 else 0.0},24,25" for x in t)
    p.write_text("time,u,k_U,T_U\n" + rows + "\n")
    return p


# ---------------------------------------------------------------- data lost or replaced
def test_simulate_refuses_to_write_over_its_input(axt_csv, capsys):
    before = axt_csv.read_bytes()
    assert main(["simulate", "axt211", "--inputs", str(axt_csv), "--out", str(axt_csv)]) == 2
    _one_error_line(capsys, "--out", "also an input", "--inputs")
    assert axt_csv.read_bytes() == before
    # the same file by another spelling is the same file
    other = axt_csv.parent / "." / axt_csv.name
    assert main(["simulate", "axt211", "--inputs", str(axt_csv), "--out", str(other)]) == 2
    assert axt_csv.read_bytes() == before


def test_montecarlo_interrupted_keeps_out_and_writes_best_so_far_elsewhere(
    strut_csv, tmp_path, capsys, monkeypatch
):
    from thermogym.identification.optimizers import base

    out = tmp_path / "fit.json"
    out.write_text('{"an": "earlier fit"}\n')
    calls = {"n": 0}
    original = base.Tracker.evaluate

    def interrupted_on_second_batch(self, *a, **kw):
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt
        return original(self, *a, **kw)

    monkeypatch.setattr(base.Tracker, "evaluate", interrupted_on_second_batch)
    argv = ["identify", "montecarlo", "--model", "strut", str(strut_csv), "--free", "r_motor"]
    argv += ["--samples", "200", "--batch-size", "50", "--out", str(out), "--no-progress"]
    assert main(argv) == 130
    err = capsys.readouterr().err
    assert out.read_text() == '{"an": "earlier fit"}\n'  # untouched
    partial = tmp_path / "fit.interrupted.json"
    assert partial.is_file() and str(partial) in err and "left unchanged" in err
    assert json.loads(partial.read_text())["model"] == "strut"
    assert not list(tmp_path.glob(".thermogym-staging-*"))
    # a second interruption does not overwrite the first best-so-far
    calls["n"] = 0
    assert main(argv) == 130
    assert (tmp_path / "fit.interrupted-2.json").is_file()


def test_interrupted_experiment_leaves_no_partial_set(tmp_path, capsys, monkeypatch):
    import thermogym.rigs as rigs

    out = tmp_path / "raw"
    n = {"files": 0}
    original = rigs.write_recording

    def dies_on_second(rec, path, **kw):
        n["files"] += 1
        if n["files"] == 2:
            raise KeyboardInterrupt
        return original(rec, path, **kw)

    monkeypatch.setattr(rigs, "write_recording", dies_on_second)
    argv = ["experiment", "spindle", "run-in", "--out", str(out), "--option", "speeds=[4000]"]
    argv += ["--option", "duration_h=0.2", "--format", "parquet"]
    assert main(argv) == 130
    assert "interrupted" in capsys.readouterr().err
    assert not out.exists() or not any(out.iterdir())  # no recordings without their manifest
    assert not [p for p in tmp_path.rglob("*") if "staging" in p.name]
    # an earlier complete set in the folder survives an interrupted rerun unchanged
    monkeypatch.setattr(rigs, "write_recording", original)
    assert main(argv) == 0
    before = _digest(out)
    assert "manifest.json" in before and len(before) == 3
    monkeypatch.setattr(rigs, "write_recording", dies_on_second)
    n["files"] = 0
    assert main([*argv, "--seed", "5"]) == 130
    assert _digest(out) == before


def test_ctrl_c_during_a_write_leaves_the_existing_output(axt_csv, tmp_path, capsys, monkeypatch):
    import thermogym.recording as recording

    out = tmp_path / "sim.csv"
    out.write_text("time,x\n0,1\n")

    def interrupted(*a, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(recording, "write_recording", interrupted)
    assert main(["simulate", "axt211", "--inputs", str(axt_csv), "--out", str(out)]) == 130
    assert out.read_text() == "time,x\n0,1\n"
    assert "nothing was written over an existing file" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ax.csv", "sim.csv"]


# ---------------------------------------------------------------- tracebacks
def test_experiment_option_of_the_wrong_type(tmp_path, capsys):
    out = tmp_path / "o"
    argv = ["experiment", "strut", "steps", "--out", str(out), "--option", "feed_rates=abc"]
    assert main(argv) == 2
    _one_error_line(capsys, "feed_rates=abc", "list of numbers", "feed_rates=[20,25,30]")
    for bad, needle in [
        ("feed_rates=[20,'x']", "'x' is not a number"),
        ("feed_rates=[-20]", "> 0"),
        ("T_air=hot", "a number"),
        ("T_air=1e6", "temperatures in"),
        ("feed_rate=20", "has no option 'feed_rate'"),
        ("feed_rates", "KEY=VALUE"),
    ]:
        assert main(["experiment", "strut", "steps", "--out", str(out), "--option", bad]) == 2
        _one_error_line(capsys, needle)
    assert not out.exists()


def test_out_naming_an_existing_file_where_a_folder_is_expected(tmp_path, capsys, strut_csv):
    f = tmp_path / "taken.txt"
    f.write_text("mine")
    assert main(["experiment", "strut", "steps", "--out", str(f)]) == 2
    _one_error_line(capsys, "--out", "is a file; expected a folder")
    argv = ["identify", "foptd", str(strut_csv), "--inputs", "feed_rate", "--outputs", "T_nut"]
    assert main([*argv, "--out", str(tmp_path / "f.json"), "--plots", str(f)]) == 2
    _one_error_line(capsys, "--plots", "is a file")
    assert f.read_text() == "mine" and not (tmp_path / "f.json").exists()


# ---------------------------------------------------------------- accepted silently
@pytest.mark.parametrize(
    ("argv", "needles"),
    [
        (
            [
                "diagnose",
                "--model",
                "strut",
                "--train",
                "x",
                "--validate",
                "x",
                "--out",
                "r.json",
                "--alpha",
                "2",
            ],
            ["--alpha", "2", "(0, 1)"],
        ),
        (["bench", "--env", "AXT211Valve", "--out", "b", "--workers", "0"], ["--workers", "0"]),
        (
            ["identify", "n4sid", "x.csv", "--out", "f.json", "--folds", "1"],
            ["--folds", "1", "in [2, 100]"],
        ),
        (
            ["identify", "foptd", "x.csv", "--out", "f.json", "--max-delay-s", "-5"],
            ["--max-delay-s", "-5 s", ">= 0 s"],
        ),
        (["--bogus"], ["--bogus"]),
        (["simulate", "--inputs", "x.csv", "--out", "y.csv", "--bogus"], ["--bogus"]),
    ],
)
def test_bad_option_values_are_one_line_errors(argv, needles, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    line = _one_error_line(capsys, *needles)
    assert "samples" not in line
    assert sorted(tmp_path.iterdir()) == []


def test_tclab_refuses_an_action_of_the_wrong_shape():
    import gymnasium as gym

    import thermogym.envs  # noqa: F401
    from thermogym.errors import ShapeError

    env = gym.make("thermogym/TCLab-v0")
    env.reset(seed=0)
    with pytest.raises(ShapeError, match=r"shape \(1,\), expected \(2,\)"):
        env.step(np.array([0.5], np.float32))
    env.step(np.array([0.5, 0.0], np.float32))  # the right shape still steps
    venv = gym.make_vec("thermogym/TCLab-v0", num_envs=3, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    with pytest.raises(ShapeError, match=r"shape \(2, 3\), expected \(3, 2\)"):
        venv.step(np.zeros((2, 3)))  # same size, transposed: never reshaped
    with pytest.raises(ShapeError):
        venv.step(np.zeros(6))
    valve = gym.make("thermogym/AXT211Valve-v0")
    valve.reset(seed=0)
    valve.step(0.2)  # a scalar for a one-element action is unambiguous


def test_demo_with_every_stage_skipped_says_so(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--only", "diagnose", "--no-progress"]) == 2
    captured = capsys.readouterr()
    assert "diagnose skipped" in captured.out  # the summary line even with --no-progress
    _one_error_line_from(captured.err, "no stage ran", "'diagnose' was skipped", "recordings")


def _one_error_line_from(err: str, *needles: str) -> None:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in lines[0], (n, lines[0])


# ---------------------------------------------------------------- unclear messages
def test_semicolon_and_decimal_comma_csv(tmp_path, capsys):
    from thermogym.recording import read_recording

    p = tmp_path / "semi.csv"
    p.write_text("time;u;k_U;T_U\n0;1,0;24,0;25,5\n1;1,0;24,0;25,5\n2;0,0;24,0;25,5\n")
    notes: list[str] = []
    rec = read_recording(p, notes=notes)
    assert rec["T_U"].tolist() == [25.5] * 3
    assert any("semicolon" in n for n in notes) and any("decimal comma" in n for n in notes)
    # a delimiter passed that does not fit: the message says which one was tried and how to pass
    out = tmp_path / "sim.csv"
    argv = ["simulate", "axt211", "--inputs", str(p), "--out", str(out)]
    assert main([*argv, "--delimiter", ","]) == 2
    _one_error_line(capsys, "delimiter comma (',')", "--delimiter ';'", "--decimal ','")
    assert not out.exists()
    assert main([*argv, "--delimiter", "semicolon", "--decimal", ","]) == 0
    printed = capsys.readouterr().out
    # given, not detected: no note about the dialect (the units note is another matter)
    dialect = [ln for ln in printed.splitlines() if ln.startswith("note:") and "unit" not in ln]
    assert out.is_file() and not dialect, dialect
    out.unlink()
    assert main(argv) == 0
    assert "detected the field delimiter semicolon" in capsys.readouterr().out


def test_time_column_named_otherwise(tmp_path, capsys):
    p = tmp_path / "tc.csv"
    p.write_text("Time,u,k_U,T_U\n0,1,24,25\n1,1,24,25\n2,0,24,25\n")
    out = tmp_path / "sim.csv"
    assert main(["simulate", "axt211", "--inputs", str(p), "--out", str(out)]) == 0
    assert "took column 'Time' as the time [s]" in capsys.readouterr().out
    q = tmp_path / "stamp.csv"
    q.write_text("stamp,clock,u,k_U,T_U\n0,5,1,24,25\n1,6,1,24,25\n2,7,0,24,25\n")
    argv = ["simulate", "axt211", "--inputs", str(q), "--out", str(tmp_path / "s2.csv")]
    assert main(argv) == 2
    _one_error_line(capsys, "no time column", "--time-column NAME")
    assert main([*argv, "--time-column", "stamp"]) == 0
    assert main([*argv, "--time-column", "nope"]) == 2
    _one_error_line(capsys, "no time column 'nope'", "'stamp', 'clock'")


def test_timestamp_jitter_is_resampled_with_a_note_and_large_steps_are_named(tmp_path, capsys):
    rng = np.random.default_rng(0)
    t = np.arange(200.0) + rng.uniform(-0.02, 0.02, 200)
    t[0] = 0.0
    rows = "\n".join(f"{x:.4f},{1.0 if i < 100 else 0.0},24,25" for i, x in enumerate(t))
    p = tmp_path / "jit.csv"
    p.write_text("time,u,k_U,T_U\n" + rows + "\n")
    out = tmp_path / "sim.csv"
    assert main(["simulate", "axt211", "--inputs", str(p), "--out", str(out)]) == 0
    note = capsys.readouterr().out
    assert "timestamp jitter" in note and "uniform 1 s grid" in note
    from thermogym.recording import Recording

    rec = Recording([0.0, 1.0, 2.0, 3.5, 4.5], {"u": np.zeros(5)})
    with pytest.raises(Exception, match=r"step of 1\.5 s from time 2 s to 3\.5 s") as e:
        rec.dt  # noqa: B018
    assert "time[" not in str(e.value) and "unlike the first" not in str(e.value)


def test_messages_show_plain_numbers_and_separate_units():
    from thermogym._checks import show, with_unit
    from thermogym._cli.common import one_line

    assert one_line("value is np.float64(30.0), expected < 10") == "value is 30.0, expected < 10"
    assert show(np.float64(2.0), "1") == "2.0" and with_unit("2", "1") == "2"
    assert with_unit("30", "K") == "30 K"


def test_progress_bars_only_on_a_terminal(tmp_path, capsys):
    from thermogym._cli.common import progress_wanted
    from thermogym.demo.core import DemoContext

    ctx = DemoContext(tmp_path, progress=True)
    assert list(ctx.bar(range(3), "items")) == [0, 1, 2]
    err = capsys.readouterr().err
    assert "\r" not in err and "\x1b[" not in err and "items" not in err
    assert progress_wanted(None) is False and progress_wanted(True) is False  # captured: no tty


# ---------------------------------------------------------------- the output guard
def test_outputs_are_checked_before_any_work(axt_csv, tmp_path, capsys):
    argv = ["simulate", "axt211", "--inputs", str(axt_csv)]
    cases = [
        (["--out", str(tmp_path / "nowhere" / "s.csv")], ["does not exist; create it first"]),
        (["--out", str(tmp_path)], ["is a folder; expected a file name"]),
        (["--out", str(tmp_path / "s.txt")], [".csv or .csv.gz or .parquet"]),
        (["--out", str(tmp_path / "s.csv"), "--plot", str(tmp_path / "p.txt")], ["--plot"]),
    ]
    for extra, needles in cases:
        assert main([*argv, *extra]) == 2
        _one_error_line(capsys, *needles)
    same = str(tmp_path / "r.json")
    diag = ["diagnose", "--model", "strut", "--train", str(axt_csv), "--validate", str(axt_csv)]
    assert main([*diag, "--out", same, "--augmented-fit", same]) == 2
    _one_error_line(capsys, "--augmented-fit and --out name the same path")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ax.csv"]


def test_an_output_over_an_inputs_sidecar_is_refused(strut_csv, tmp_path, capsys):
    """A JSON output named like an input CSV's ``.meta.json`` would replace its metadata."""
    data = tmp_path / "a.csv"
    data.write_bytes(strut_csv.read_bytes())
    side = tmp_path / "a.csv.meta.json"
    side.write_bytes((strut_csv.parent / (strut_csv.name + ".meta.json")).read_bytes())
    bare = tmp_path / "b.csv"  # no sidecar yet: one written there would be read with it
    bare.write_bytes(strut_csv.read_bytes())
    before = _digest(tmp_path)
    foptd = ["identify", "foptd", "--inputs", "feed_rate", "--outputs", "T_drive"]
    diag = ["diagnose", "--model", "strut", "--train", str(data), "--validate", str(bare)]
    cases = [
        ([*foptd, str(data), "--out", str(side)], ["--out", "sidecar of", "a.csv"]),
        ([*foptd, str(bare), "--out", str(tmp_path / "b.csv.meta.json")], ["sidecar of"]),
        ([*diag, "--out", str(tmp_path / "b.csv.meta.json")], ["--validate", "b.csv"]),
        ([*diag, "--out", str(tmp_path / "r.json"), "--augmented-fit", str(side)], ["--train"]),
    ]
    for argv, needles in cases:
        assert main(argv) == 2, argv
        _one_error_line(capsys, "also an input", *needles)
        assert _digest(tmp_path) == before, argv


def test_rls_from_fit_reads_the_fits_columns_at_the_fits_period(strut_csv, tmp_path, capsys):
    data = tmp_path / "a.csv"  # no sidecar: no roles to reorder the columns by
    data.write_bytes(strut_csv.read_bytes())
    lines = data.read_text().splitlines()
    half = tmp_path / "half.csv"  # every second sample: twice the period
    half.write_text("\n".join([lines[0], *lines[1::2]]) + "\n")
    fit = tmp_path / "f.json"
    cols = ["--inputs", "feed_rate,T_air", "--outputs", "T_drive,T_nut"]
    assert main(["identify", "foptd", str(data), *cols, "--out", str(fit)]) == 0
    before = _digest(tmp_path)
    rls = ["identify", "rls", "--from-fit", str(fit)]
    out = tmp_path / "r.json"
    # the fit's columns, some left out: named (was a ShapeError on array shapes)
    argv = [*rls, str(data), "--inputs", "feed_rate", "--outputs", "T_drive", "--out", str(out)]
    assert main(argv) == 2
    _one_error_line(capsys, "--inputs ['feed_rate']", "'T_air'", "f.json")
    # another period than the fit's: named (was fed on as if sampled at the fit's period)
    assert main([*rls, str(half), *cols, "--out", str(out)]) == 2
    _one_error_line(capsys, "'half'", "281.8 s", "140.9 s")
    assert main(["identify", "rls", str(data), str(half), *cols, "--out", str(out)]) == 2
    _one_error_line(capsys, "'half'", "281.8 s")
    assert _digest(tmp_path) == before
    # the same columns in another order: each gain stays with its column (were swapped)
    assert main([*rls, str(data), *cols, "--out", str(out)]) == 0
    own = json.loads(out.read_text())["parameters"]
    swapped = ["--inputs", "T_air,feed_rate", "--outputs", "T_nut,T_drive"]
    assert main([*rls, str(data), *swapped, "--out", str(out)]) == 0
    assert json.loads(out.read_text())["parameters"] == pytest.approx(own)


def test_a_folders_manifest_of_the_wrong_shape_is_named(strut_csv, tmp_path, capsys):
    folder = tmp_path / "set"
    folder.mkdir()
    (folder / "a.csv").write_bytes(strut_csv.read_bytes())
    argv = ["identify", "foptd", str(folder), "--inputs", "feed_rate", "--outputs", "T_drive",
            "--out", str(tmp_path / "f.json")]  # fmt: skip
    cases = [  # an empty list was an IndexError (internal error); a file listed twice was fitted
        ({"recordings": []}, ["manifest.json", "lists no recording", '"recordings"']),
        ({"recordings": [{"file": "a.csv"}, {"file": "a.csv"}]}, ["['a.csv'] more than once"]),
        ({"recordings": {"a": 1}}, ["manifest.json", "does not list", '"file": NAME']),
        ({"recordings": [{"id": "a"}]}, ["manifest.json", "does not list", '"file": NAME']),
        (["a.csv"], ["manifest.json", "does not list"]),
    ]
    for doc, needles in cases:
        (folder / "manifest.json").write_text(json.dumps(doc))
        before = _digest(tmp_path)
        assert main(argv) == 2, doc
        _one_error_line(capsys, str(folder), *needles)
        assert _digest(tmp_path) == before


def test_a_failed_run_replaces_nothing(axt_csv, tmp_path, capsys):
    out = tmp_path / "sim.csv"
    out.write_text("time,x\n0,1\n")
    # the plot fails after the simulation: the recording is not published either
    bad = tmp_path / "p.png"
    bad.mkdir()
    assert (
        main(
            ["simulate", "axt211", "--inputs", str(axt_csv), "--out", str(out), "--plot", str(bad)]
        )
        == 2
    )
    capsys.readouterr()
    assert out.read_text() == "time,x\n0,1\n"
    from thermogym._cli.common import OutputPlan

    plan = OutputPlan()
    plan.file("--out", out, "csv")
    with pytest.raises(RuntimeError):
        with plan:
            plan.path("--out").write_text("half")
            raise RuntimeError("the command failed")
    assert out.read_text() == "time,x\n0,1\n"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".thermogym")]
    with OutputPlan() as plan2:
        plan2.file("--out", out, "csv")
        plan2.path("--out").write_text("new")
        assert out.read_text() == "time,x\n0,1\n"  # replaced only at the end
    assert out.read_text() == "new"


def test_dataset_recordings_are_accepted_everywhere(tmp_path, capsys, strut_csv):
    fit = tmp_path / "f.json"
    assert (
        main(
            [
                "identify",
                "foptd",
                "dataset:hair_dryer",
                "--operating-point",
                "mean",
                "--out",
                str(fit),
            ]
        )
        == 0
    )
    capsys.readouterr()
    assert (
        main(
            [
                "simulate",
                "--params",
                str(fit),
                "--inputs",
                "dataset:hair_dryer",
                "--out",
                str(tmp_path / "s.csv"),
            ]
        )
        == 0
    )
    assert " fit " in capsys.readouterr().out
    assert main(["identify", "foptd", "dataset:nope", "--out", str(tmp_path / "g.json")]) == 2
    _one_error_line(capsys, "unknown data set 'nope'", "hair_dryer")
    # --prepare on every identify method, recordings after it are still recordings
    argv = ["identify", "montecarlo", "--model", "strut", "--free", "r_motor", "--samples", "20"]
    argv += ["--no-progress", "--out", str(tmp_path / "g.json"), "--prepare", "outliers=false"]
    assert main([*argv, str(strut_csv)]) == 0
    assert json.loads((tmp_path / "g.json").read_text())["model"] == "strut"
    assert main([*argv, "hampel_window=0", str(strut_csv)]) == 2
    _one_error_line(capsys, "--prepare hampel_window = 0", ">= 1")


# ---------------------------------------------------------------- demo --only
def _stub_stages(calls: dict[str, int], interrupt: bool = False):
    from thermogym.demo import Stage
    from thermogym.demo.core import StageSkipped

    def run_a(ctx, res):
        calls["a"] = calls.get("a", 0) + 1
        ctx.path("data", "a.txt").write_text("from a")
        ctx.products["a"] = "from a"
        res.text = "stage a ran"

    def load_a(ctx):
        p = ctx.out / "data" / "a.txt"
        if not p.is_file():
            raise StageSkipped("no a.txt")
        ctx.products["a"] = p.read_text()

    def run_b(ctx, res):
        ctx.need("a")
        calls["b"] = calls.get("b", 0) + 1
        ctx.path("b", "b.txt").write_text(ctx.products["a"] + " via b")
        if interrupt:
            raise KeyboardInterrupt
        res.text = "stage b ran"

    return [Stage("a", "A", run_a, load_a), Stage("b", "B", run_b)]


def test_demo_only_keeps_and_reuses_earlier_stages(tmp_path):
    from thermogym.demo import run_demo

    calls: dict[str, int] = {}
    run_demo(tmp_path, stages=_stub_stages(calls), progress=False)
    man0 = json.loads((tmp_path / "manifest.json").read_text())["stages"]
    a_files = _digest(tmp_path / "data")
    # --only b: a is not run, its outputs are reused, its files and section stay
    res = run_demo(tmp_path, stages=_stub_stages(calls), only=["b"], progress=False)
    assert [(r.key, r.status) for r in res] == [("b", "ok")] and calls == {"a": 1, "b": 2}
    assert _digest(tmp_path / "data") == a_files
    man = json.loads((tmp_path / "manifest.json").read_text())["stages"]
    assert man["a"] == man0["a"] and man["b"]["ran_at"]
    md = (tmp_path / "report.md").read_text()
    assert "stage a ran" in md and "stage b ran" in md
    assert f"this section and its files are from the run of {man0['a']['ran_at']}" in md
    # --only b when a's outputs are gone: b is skipped and keeps its earlier files and section
    (tmp_path / "data" / "a.txt").unlink()
    b_files = _digest(tmp_path / "b")
    res = run_demo(tmp_path, stages=_stub_stages(calls), only=["b"], progress=False)
    assert res[0].status == "skipped" and "no a.txt" in res[0].error
    assert _digest(tmp_path / "b") == b_files
    man2 = json.loads((tmp_path / "manifest.json").read_text())["stages"]
    assert man2["b"]["files"] == man["b"]["files"] and "needs ['a']" in man2["b"]["skipped"]
    md = (tmp_path / "report.md").read_text()
    assert "stage b ran" in md and "Skipped this time" in md


def test_demo_interrupted_stage_publishes_nothing_and_the_report_stays_consistent(tmp_path):
    from thermogym.demo import run_demo

    calls: dict[str, int] = {}
    run_demo(tmp_path, stages=_stub_stages(calls), progress=False)
    before = _digest(tmp_path / "b")
    man0 = json.loads((tmp_path / "manifest.json").read_text())["stages"]
    with pytest.raises(KeyboardInterrupt):
        run_demo(tmp_path, stages=_stub_stages(calls, interrupt=True), progress=False)
    assert _digest(tmp_path / "b") == before
    man = json.loads((tmp_path / "manifest.json").read_text())["stages"]
    assert man["b"] == man0["b"] and man["a"]["ran_at"] >= man0["a"]["ran_at"]
    md = (tmp_path / "report.md").read_text()
    assert "Interrupted this time" in md and "stage b ran" in md  # the earlier section, marked
    assert not list(tmp_path.glob(".staging-*"))


def test_demo_reuses_real_rig_recordings(tmp_path):
    from thermogym.demo import STAGES, Stage, run_demo

    seen = {}

    def uses_recordings(ctx, res):
        ctx.need("recordings")
        seen.update({k: len(v) for k, v in ctx.products["recordings"].items()})

    stages = [STAGES[0], Stage("use", "Use", uses_recordings)]
    assert (
        run_demo(tmp_path, quick=True, only=["rigs"], stages=stages, progress=False)[0].status
        == "ok"
    )
    rec_files = _digest(tmp_path / "recordings")
    res = run_demo(tmp_path, quick=True, only=["use"], stages=stages, progress=False)
    assert res[0].status == "ok"
    assert seen["strut/steps"] == 3 and seen["spindle/run-in"] == 2 and seen["axt211/steps"] == 9
    assert _digest(tmp_path / "recordings") == rec_files
    # another seed: the earlier recordings are not this run's, so they are not reused
    res = run_demo(tmp_path, quick=True, seed=1, only=["use"], stages=stages, progress=False)
    assert res[0].status == "skipped" and "from seed 0" in res[0].error


def test_spreadsheet_exports_read_or_named(tmp_path):
    from thermogym.errors import RecordingError
    from thermogym.recording import read_recording

    rows = "0,1,2\n1,1,3\n2,0,2\n"
    (tmp_path / "bom.csv").write_bytes(b"\xef\xbb\xbftime,u,y\n" + rows.encode())
    assert read_recording(tmp_path / "bom.csv").columns == ("u", "y")
    (tmp_path / "c.csv").write_text("# logged 2024\n# by hand\ntime,u,y\n" + rows)
    notes: list[str] = []
    assert read_recording(tmp_path / "c.csv", notes=notes).n_samples == 3
    assert notes == ["skipped 2 comment line(s) (# ...) before the header"]
    (tmp_path / "u.csv").write_text("time,u,y\ns,V,V\n" + rows)
    with pytest.raises(RecordingError, match="units row"):
        read_recording(tmp_path / "u.csv")
    (tmp_path / "t.csv").write_text("time,u,y,\n0,1,2,\n1,1,3,\n")
    with pytest.raises(RecordingError, match="empty name"):
        read_recording(tmp_path / "t.csv")


# ---------------------------------------------------------------- second review (issue 17)
def test_diagnose_names_the_models_as_the_user_wrote_them(tmp_path, capsys):
    fit = tmp_path / "ss.json"
    data = "dataset:hair_dryer"
    assert main(["identify", "n4sid", data, "--order", "2", "--out", str(fit)]) == 0
    capsys.readouterr()
    argv = ["diagnose", "--model", "ss:3", "--params", str(fit), "--inputs", "u", "--outputs"]
    argv += ["y", "--train", data, "--validate", data, "--out", str(tmp_path / "r.json")]
    assert main(argv) == 2  # a 2-state fit handed in as the nominal of ss:3
    captured = capsys.readouterr()
    line = _one_error_line_from_text(captured.err)
    assert "'ss:3'" in line and "model 'ss' with 2 states" in line and "--model ss:2" in line
    assert "augmented'" not in line  # the internal wrapper is not the user's model
    assert "model ss:3:" in captured.out and "model augmented" not in captured.out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ss.json"]
    # a FitResult of another model: named, with the ways out
    foptd = tmp_path / "foptd.json"
    argv_f = ["identify", "foptd", data, "--input", "u", "--output", "y", "--out", str(foptd)]
    assert main(argv_f) == 0
    capsys.readouterr()
    argv[argv.index(str(fit))] = str(foptd)
    assert main(argv) == 2
    line = _one_error_line_from_text(capsys.readouterr().err)
    assert "'foptd'" in line and "'ss:3'" in line and "--augmented-fit" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["foptd.json", "ss.json"]


def _one_error_line_from_text(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_diagnosis_table_keeps_units_apart_and_drops_dimensionless_ones():
    from thermogym.identification.diagnosis.report import DiagnosisReport

    rep = DiagnosisReport(
        "strut", {}, ["T_nut"], ["feed_rate"], {"T_nut": "°C"}, True, 0.01, {}, {}, None, {}
    )  # type: ignore[arg-type]
    rep.hypotheses = [
        {
            "effect": "input_dependent_heat_transfer",
            "target": "T_nut",
            "params": {
                "beta_u": {"value": 2.0, "unit": "1"},
                "tau_lag": {"value": 30.0, "unit": "s"},
                "gain": {"value": 0.5, "unit": ""},
            },
        }
    ]
    assert rep._hyp_rows()[0][3] == "beta_u = 2, tau_lag = 30 s, gain = 0.5"


def test_demo_bars_follow_the_terminal(tmp_path, monkeypatch):
    import sys

    from thermogym.demo.core import DemoContext

    ctx = DemoContext(tmp_path, progress=True)
    assert ctx.bars is False  # pytest captures stderr: not a terminal
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    assert ctx.bars is True and DemoContext(tmp_path, progress=False).bars is False


def test_demo_only_keeps_an_earlier_failure_in_the_report(tmp_path):
    from thermogym.demo import Stage, run_demo

    calls: dict[str, int] = {}

    def fails(ctx, res):
        res.highlights["b"] = "half done"
        raise RuntimeError("b broke")

    stages = [_stub_stages(calls)[0], Stage("b", "B", fails)]
    run_demo(tmp_path, stages=stages, progress=False)
    log = (tmp_path / "logs" / "b.txt").read_text()
    run_demo(tmp_path, stages=stages, only=["a"], progress=False)
    md = (tmp_path / "report.md").read_text()
    assert "**FAILED** B: RuntimeError: b broke" in md
    assert "| B | failed (earlier run," in md and "Not run this time: it failed" in md
    assert (tmp_path / "logs" / "b.txt").read_text() == log
    # an earlier report without the section: the manifest still says it failed
    doc = json.loads((tmp_path / "report.json").read_text())
    doc["sections"] = [s for s in doc["sections"] if s["key"] != "b"]
    (tmp_path / "report.json").write_text(json.dumps(doc))
    run_demo(tmp_path, stages=stages, only=["a"], progress=False)
    md = (tmp_path / "report.md").read_text()
    assert "**FAILED** B: see logs/b.txt" in md


def test_python_api_refuses_text_where_numbers_belong(tmp_path):
    import gymnasium as gym

    import thermogym.envs  # noqa: F401
    from thermogym.errors import ParameterError, RecordingError, ShapeError
    from thermogym.models.registry import get_model
    from thermogym.recording import read_recording

    with pytest.raises(ParameterError, match=r"parameter 'C_P' of model 'axt211' is 'abc'"):
        gym.make("thermogym/AXT211Valve-v0", params={"C_P": "abc"})
    with pytest.raises(RecordingError, match=r"the recording path is a int \(5\)"):
        read_recording(5)  # type: ignore[arg-type]
    m = get_model("axt211")
    with pytest.raises(ShapeError, match=r"u cannot be read as numbers"):
        m.simulate([["a", "b", "c"]], 1.0)
    with pytest.raises(ShapeError, match=r"dt is '1'"):
        m.simulate(np.zeros((3, 3)), "1")  # type: ignore[arg-type]
    with pytest.raises(ShapeError, match=r"dt is True"):
        m.simulate(np.zeros((3, 3)), True)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match=r"theta cannot be read as numbers"):
        m.theta([["x"] * len(m.param_names)])
    assert m.simulate(np.zeros((3, 3)), np.float64(1.0)).outputs.shape[1] == 3  # numbers work


class _WorkStarted(BaseException):
    """Raised by a hooked function: the command started work before refusing an option."""


#: One bad option value per command and sub-command, with a word its error names; each must
#: be refused before any recording is read, rig run, benchmark or demo started.
_EARLY = [
    (["simulate", "axt211", "--inputs", "ax.csv", "--out", "s.csv", "--set", "C_P=abc"], "C_P"),
    (["simulate", "axt211", "--inputs", "ax.csv", "--out", "s.csv", "--set", "C_P=1", "--set",
      "C_P=2"], "C_P"),
    (["simulate", "axt211", "--inputs", "ax.csv", "--out", "s.txt"], "--out"),
    (["simulate", "axt211", "--inputs", "ax.csv", "--out", "s.csv", "--delimiter", "ab"],
     "--delimiter"),
    (["experiment", "strut", "steps", "--out", "e", "--option", "feed_rates=abc"], "feed_rates"),
    (["experiment", "strut", "steps", "--out", "e", "--effect", "gremlins"], "gremlins"),
    (["identify", "foptd", "hd.csv", "--out", "f.json", "--max-delay-s", "-5"], "--max-delay-s"),
    (["identify", "foptd", "hd.csv", "--out", "f.json", "--prepare", "dt=abc"], "dt"),
    (["identify", "n4sid", "hd.csv", "--out", "f.json", "--orders", "5:2"], "--orders"),
    (["identify", "n4sid", "hd.csv", "--out", "f.json", "--decimate", "x"], "--decimate"),
    (["identify", "rls", "hd.csv", "--out", "f.json", "--forgetting", "2"], "--forgetting"),
    (["identify", "arx", "hd.csv", "--out", "f.json", "--na", "abc"], "--na"),
    (["identify", "armax", "hd.csv", "--out", "f.json", "--nc", "-1"], "--nc"),
    (["identify", "oe", "hd.csv", "--out", "f.json", "--nf", "x"], "--nf"),
    (["identify", "bj", "hd.csv", "--out", "f.json", "--nd", "1;x"], "--nd"),
    (["identify", "sopdt", "hd.csv", "--out", "f.json", "--max-delay-s", "-1"], "--max-delay-s"),
    (["identify", "ssest", "hd.csv", "--out", "f.json", "--orders", "3:1"], "--orders"),
    (["identify", "ssest", "hd.csv", "--out", "f.json", "--input-delay", "1,2"], "--input-delay"),
    (["identify", "auto", "hd.csv", "--out", "f.json", "--families", "arx,zz"], "zz"),
    (["identify", "montecarlo", "--model", "strut", "strut.csv", "--free", "r_motor=3:1",
      "--out", "f.json"], "r_motor"),
    (["identify", "greybox", "--model", "strut", "strut.csv", "--free", "r_motor", "--pair",
      "T_nut@abc", "--out", "f.json"], "T_nut"),
    (["identify", "anneal", "--model", "strut", "strut.csv", "--free", "r_motor", "--fix",
      "r_nut=abc", "--out", "f.json"], "r_nut"),
    (["identify", "evolution", "--model", "nope", "strut.csv", "--out", "f.json"], "nope"),
    (["identify", "cmaes", "--model", "strut", "strut.csv", "--free", "r_motor", "--sigma0",
      "0", "--out", "f.json"], "--sigma0"),
    (["compare", "fit_ss.json", "--data", "hd.csv", "--k-step", "0"], "--k-step"),
    (["compare", "fit_ss.json", "--data", "hd.csv", "--labels", "a,b"], "--labels"),
    (["resid", "fit_ss.json", "--data", "hd.csv", "--alpha", "2"], "--alpha"),
    (["diagnose", "--model", "nope", "--train", "hd.csv", "--validate", "hd.csv", "--out",
      "r.json"], "nope"),
    (["diagnose", "--model", "strut", "--train", "strut.csv", "--validate", "strut.csv",
      "--out", "r.json", "--candidates", "gremlins"], "gremlins"),
    (["virtual-sensor", "hd.csv", "--fit", "fit_ss.json", "--out", "v.csv", "--rest", "u=nan"],
     "u"),
    (["virtual-sensor", "hd.csv", "--fit", "fit_ss.json", "--out", "v.csv",
      "--measurement-std", "0"], "--measurement-std"),
    (["firmware", "budget", "fit_ss.json", "--range", "u=5:1"], "u="),
    (["firmware", "export", "fit_ss.json", "--out", "fw", "--offset", "u=abc"], "u=abc"),
    (["bench", "--env", "AXT211Valve", "--out", "b", "--seed-list", "1,x"], "--seed-list"),
    (["bench", "--env", "AXT211Valve", "--out", "b", "--controllers", "onoff,zz"], "zz"),
    (["bench", "--env", "Nope", "--out", "b"], "Nope"),
    (["demo", "--out", "d", "--only", "nope"], "--only"),
    (["demo", "--out", "d", "--seed", "-1"], "--seed"),
    (["models", "nope"], "nope"),
    (["simulate", "nope", "--inputs", "ax.csv", "--out", "s.csv"], "nope"),
    (["simulate", "ss:x", "--inputs", "ax.csv", "--out", "s.csv"], "ss:x"),
    (["identify", "rls", "hd.csv", "--out", "f.json", "--delays", "a"], "--delays"),
    (["identify", "foptd", "hd.csv", "--out", "f.json", "--model", "nope"], "nope"),
    (["identify", "n4sid", "hd.csv", "--out", "f.json", "--expect-sign", "u=?"], "u=?"),
    (["identify", "arx", "hd.csv", "--out", "f.json", "--model", "nope"], "nope"),
    (["identify", "foptd", "hd.csv", "--inputs", "u", "--outputs", "y", "--out", "f.json",
      "--y-offset", "T=1"], "--y-offset names 'T'"),
    (["identify", "ssest", "hd.csv", "--inputs", "u", "--outputs", "y", "--out", "f.json",
      "--u-offset", "u=inf"], "inf is not finite"),
    (["identify", "montecarlo", "--model", "strut", "strut.csv", "--effects", "gremlins",
      "--out", "f.json"], "gremlins"),
    (["identify", "montecarlo", "--model", "strut", "strut.csv", "--ratio", "r_nut", "--out",
      "f.json"], "--ratio"),
    (["identify", "montecarlo", "--model", "strut", "strut.csv", "--free", "r_motor",
      "--input-noise", "feed_rate=-1", "--out", "f.json"], "feed_rate"),
    (["identify", "montecarlo", "--external", "missing.toml", "hd.csv", "--out", "f.json"],
     "missing.toml"),
    (["firmware", "budget", "fit_ss.json", "--target", "z80"], "z80"),
    (["bench", "--env", "AXT211Valve", "--out", "b", "--plant", "moon"], "moon"),
    (["bench", "--env", "AXT211Valve", "--out", "b", "--scenario", "nope"], "nope"),
]  # fmt: skip


@pytest.mark.parametrize(("argv", "needle"), _EARLY, ids=[" ".join(a[:2]) for a, _ in _EARLY])
def test_every_command_refuses_a_bad_option_before_any_work(
    argv, needle, tmp_path, capsys, monkeypatch
):
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    import cli_badinput as cb

    import thermogym.controllers.harness as harness
    import thermogym.datasets as datasets
    import thermogym.demo as demo
    import thermogym.recording as recording
    import thermogym.rigs as rigs

    for name, data in cb.build_fixtures().items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(data)
    monkeypatch.chdir(tmp_path)
    before = _digest(tmp_path)

    def work(*a, **kw):
        raise _WorkStarted

    for owner, attr in [(recording, "read_recording"), (datasets, "load"),
                        (rigs, "run_experiment"), (harness, "run_benchmark"),
                        (demo, "run_demo")]:  # fmt: skip
        monkeypatch.setattr(owner, attr, work)
    assert main(argv) == 2
    _one_error_line(capsys, needle)
    assert _digest(tmp_path) == before


# ---------------------------------------------------------------- unlisted bad inputs
def test_recordings_in_other_encodings_are_named(tmp_path):
    from thermogym.errors import RecordingError
    from thermogym.recording import read_recording

    text = "time,u,T_U\n0,1,20\n1,1,21\n2,0,21\n"
    for enc, named in [("utf-16", "UTF-16 text"), ("utf-16-le", "looks like UTF-16"),
                       ("utf-32", "UTF-32 text")]:  # fmt: skip
        p = tmp_path / f"{enc}.csv"
        p.write_bytes(text.encode(enc))
        with pytest.raises(RecordingError, match=named):
            read_recording(p)
    p = tmp_path / "latin.csv"
    p.write_bytes(text.replace("T_U", "T_U [°C]").encode("latin-1"))
    with pytest.raises(RecordingError, match=r"not UTF-8 text: byte 0xb0 on line 1"):
        read_recording(p)
    p.write_bytes(b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode())  # BOM and CRLF: fine
    assert read_recording(p)["T_U"].tolist() == [20.0, 21.0, 21.0]
    import gzip

    p = tmp_path / "packed.csv"  # gzip content without .gz: was "not UTF-8 ... Latin-1?"
    p.write_bytes(gzip.compress(text.encode()))
    with pytest.raises(RecordingError, match=r"packed\.csv' is gzip-compressed.*'packed\.csv\.gz'"):
        read_recording(p)


def test_fitresult_with_a_bom_reads_and_a_deep_one_is_named(tmp_path, axt_csv, capsys):
    from thermogym.fitresult import FitResult
    from thermogym.models.registry import get_model

    fit = FitResult.from_model(get_model("axt211"), {"C_P": 20.0}, method="by hand")
    p = tmp_path / "bom.json"
    p.write_bytes(b"\xef\xbb\xbf" + json.dumps(fit.to_dict()).encode())
    assert FitResult.load(p).parameters["C_P"] == 20.0
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    argv = ["simulate", "--params", str(deep), "--inputs", str(axt_csv), "--out"]
    assert main([*argv, str(tmp_path / "s.csv")]) == 2
    _one_error_line(capsys, "deep.json", "nested too deeply")


def test_unusable_output_names_are_refused_first(axt_csv, tmp_path, capsys):
    argv = ["simulate", "axt211", "--inputs", str(axt_csv), "--out"]
    for out, needle in [
        (str(tmp_path / "s\x00.csv"), "NUL character"),
        (str(tmp_path / ("x" * 300 + ".csv")), "file names take at most"),
        (str(tmp_path / "/".join(["d"] * 3000)) + "/s.csv", "bytes long (absolute)"),
        (str(tmp_path / "s.csv") + "/", "ends in a '/'"),
    ]:
        assert main([*argv, out]) == 2
        _one_error_line(capsys, needle)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ax.csv"]


def test_long_messages_keep_their_end():
    from thermogym._cli.common import one_line

    msg = "--out '" + "d/" * 1000 + "x.csv': its folder does not exist; create it first"
    line = one_line(msg)
    assert len(line) <= 800 and line.startswith("--out '") and line.endswith("create it first")


def test_a_time_axis_in_the_wrong_unit_is_refused_not_run():
    from thermogym.errors import SimulationError
    from thermogym.models.registry import get_model

    m = get_model("axt211")  # 1 s integrator steps: 1e9 s would take 1e9 of them
    with pytest.raises(SimulationError, match=r"1e\+09 integrator steps .* is the time in seconds"):
        m.simulate(np.array([[1.0, 24.0, 25.0]] * 2), 1e9)


def test_rig_options_out_of_its_physics_write_nothing(tmp_path, capsys):
    from thermogym.errors import SimulationError
    from thermogym.rigs import run_experiment

    with pytest.raises(SimulationError, match=r"outside what the rig can hold"):
        run_experiment("strut", "steps", tmp_path / "py", feed_rates=[1e300])
    argv = ["experiment", "axt211", "steps", "--out", str(tmp_path / "cli"), "--option"]
    assert main([*argv, "voltages=[1e6]", "--option", "ambients=[25]"]) == 2
    _one_error_line(capsys, "axt211-step-1e+06V-25C", "T_P", "out of its physics")
    assert not (tmp_path / "cli").exists() and not (tmp_path / "py").exists()


def test_virtual_sensor_at_a_very_long_period_is_exact_and_quick():
    from thermogym.estimation.virtual_sensor import _lyapunov_sum

    rng = np.random.default_rng(1)
    A = 0.3 * rng.standard_normal((3, 3))
    Q = np.cov(rng.standard_normal((3, 10)))
    for k in (1, 2, 5, 64, 333):
        direct = sum(
            np.linalg.matrix_power(A, i) @ Q @ np.linalg.matrix_power(A, i).T for i in range(k)
        )
        assert np.allclose(_lyapunov_sum(A, Q, k), direct, rtol=1e-10, atol=1e-12)
    # 10^10 terms (a period 10^10 times the model's): the geometric series' limit
    A1 = np.array([[0.5]])
    assert _lyapunov_sum(A1, np.array([[3.0]]), 10**10)[0, 0] == pytest.approx(3.0 / 0.75)


def test_out_of_memory_is_one_line(axt_csv, tmp_path, capsys, monkeypatch):
    import thermogym.recording as recording

    def no_memory(*a, **kw):
        raise MemoryError

    monkeypatch.setattr(recording, "read_recording", no_memory)
    argv = ["simulate", "axt211", "--inputs", str(axt_csv), "--out", str(tmp_path / "s.csv")]
    assert main(argv) == 2
    _one_error_line(capsys, "out of memory")


def test_resid_says_when_it_used_fewer_lags(tmp_path, capsys):
    fit = tmp_path / "ss.json"
    assert main(["identify", "n4sid", "dataset:hair_dryer", "--order", "2", "--out", str(fit)]) == 0
    capsys.readouterr()
    assert main(["resid", str(fit), "--data", "dataset:hair_dryer", "--max-lag", "100000"]) == 0
    out = capsys.readouterr().out
    assert "lags up to 250 (--max-lag 100000 reduced to a quarter of the samples)" in out


def test_demo_interrupted_before_any_stage_finished_changes_no_file(tmp_path, capsys, monkeypatch):
    import thermogym.demo as demo

    calls: dict[str, int] = {}
    demo.run_demo(tmp_path, stages=_stub_stages(calls), progress=False)
    before = _digest(tmp_path)
    monkeypatch.setattr(demo, "STAGES", _stub_stages(calls, interrupt=True))
    argv = ["demo", "--out", str(tmp_path), "--only", "b", "--no-progress"]
    assert main(argv) == 130
    line = _one_error_line_from_text(capsys.readouterr().err)
    assert "stage 'b' published nothing; every file in" in line and "as it was" in line
    assert _digest(tmp_path) == before  # the reports too: nothing they describe changed
    # a stage that finished first: its files and the reports change, and the line says so
    assert main(["demo", "--out", str(tmp_path), "--no-progress"]) == 130
    line = _one_error_line_from_text(capsys.readouterr().err)
    assert "stage(s) ['a'] finished before it" in line and "were rewritten" in line
    assert "Interrupted this time" in (tmp_path / "report.md").read_text()


def test_diagnose_a_generic_model_on_a_one_output_recording(tmp_path, capsys):
    d = np.loadtxt(Path(__file__).parents[1] / "thermogym/datasets/data/daisy_hair_dryer/dryer.dat")
    rows = "\n".join(f"{0.08 * i:.2f},{u:g},{y:g}" for i, (u, y) in enumerate(d[:300]))
    hd = tmp_path / "hd.csv"
    hd.write_text("time,u,y\n" + rows + "\n")
    argv = ["diagnose", "--model", "ss:3", "--train", str(hd), "--validate", str(hd)]
    out = tmp_path / "r.json"
    assert main([*argv, "--out", str(out)]) == 2  # a generic model: name its columns
    _one_error_line(capsys, "'ss:3' is generic", "--inputs", "--outputs")
    assert main([*argv, "--inputs", "u", "--outputs", "y", "--out", str(out), "--quiet"]) == 0
    rep = json.loads(out.read_text())
    assert rep["outputs"] == ["y"] and rep["model"] == "ss:3"  # the user's name, not the wrapper
    assert "fewer than 8 valid samples" not in capsys.readouterr().err


def test_python_api_names_wrong_types_of_recordings_options_and_levels(strut_csv):
    from thermogym.errors import ConfigError, RecordingError
    from thermogym.identification.diagnosis import diagnose
    from thermogym.identification.foptd import fit_foptd
    from thermogym.identification.n4sid import n4sid
    from thermogym.recording import read_recording
    from thermogym.rigs import run_experiment

    with pytest.raises(RecordingError, match=r"the recordings are a str \('hd.csv'\)"):
        fit_foptd("hd.csv", ["u"], ["y"])
    with pytest.raises(RecordingError, match=r"a recording is a str \('hd.csv'\)"):
        n4sid(["hd.csv"], ["u"], ["y"], 2)
    with pytest.raises(ConfigError, match=r"option feed_rates = 'abc'; expected a list"):
        run_experiment("strut", "steps", feed_rates="abc")
    with pytest.raises(ConfigError, match=r"option T_air = \[21\]; expected a finite number"):
        run_experiment("strut", "steps", T_air=[21])
    with pytest.raises(ConfigError, match=r"seed is 'x'"):
        run_experiment("strut", "steps", seed="x")  # type: ignore[arg-type]
    rec = read_recording(strut_csv)
    with pytest.raises(ConfigError, match=r"alpha = 2, expected a finite number in \(0, 1\)"):
        diagnose("strut", [rec], [rec], alpha=2)


def test_sigterm_is_an_interruption_too(axt_csv, tmp_path, capsys, monkeypatch):
    import os
    import signal

    import thermogym.recording as recording

    out = tmp_path / "sim.csv"
    out.write_text("time,x\n0,1\n")
    original = recording.write_recording

    def killed_while_writing(rec, path, **kw):
        original(rec, path, **kw)  # the staged file is written ...
        os.kill(os.getpid(), signal.SIGTERM)  # ... then `kill` arrives

    monkeypatch.setattr(recording, "write_recording", killed_while_writing)
    before = signal.getsignal(signal.SIGTERM)
    argv = ["simulate", "axt211", "--inputs", str(axt_csv), "--out", str(out)]
    assert main(argv) == 128 + signal.SIGTERM
    line = _one_error_line_from_text(capsys.readouterr().err)
    assert "terminated by SIGTERM: nothing was written over an existing file" in line
    assert out.read_text() == "time,x\n0,1\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ax.csv", "sim.csv"]
    assert signal.getsignal(signal.SIGTERM) is before  # the handler is put back


def test_sigterm_in_a_search_keeps_its_best_so_far_and_in_the_demo_the_reports(
    strut_csv, tmp_path, capsys, monkeypatch
):
    import os
    import signal

    import thermogym.demo as demo
    from thermogym.identification.optimizers import base

    out = tmp_path / "fit.json"
    out.write_text('{"an": "earlier fit"}\n')
    calls = {"n": 0}
    original = base.Tracker.evaluate

    def killed_on_second_batch(self, *a, **kw):
        calls["n"] += 1
        if calls["n"] == 2:
            os.kill(os.getpid(), signal.SIGTERM)  # `kill PID` while the search runs
        return original(self, *a, **kw)

    monkeypatch.setattr(base.Tracker, "evaluate", killed_on_second_batch)
    argv = ["identify", "montecarlo", "--model", "strut", str(strut_csv), "--free", "r_motor"]
    argv += ["--samples", "200", "--batch-size", "50", "--out", str(out), "--no-progress"]
    assert main(argv) == 128 + signal.SIGTERM  # the search swallowed it; the status tells
    line = _one_error_line_from_text(capsys.readouterr().err)
    partial = tmp_path / "fit.interrupted.json"
    assert line.startswith("thermogym identify: terminated by SIGTERM: the search was stopped")
    assert str(partial) in line and "left unchanged" in line
    assert out.read_text() == '{"an": "earlier fit"}\n' and partial.is_file()
    # the demo handles SIGTERM like Ctrl-C: the reports match the stages that finished
    folder = tmp_path / "demo"
    stages = _stub_stages(calls)
    demo.run_demo(folder, stages=stages, progress=False)
    killed = _stub_stages(calls)

    def run_b_killed(ctx, res):
        os.kill(os.getpid(), signal.SIGTERM)

    killed[1] = demo.Stage("b", "B", run_b_killed)
    monkeypatch.setattr(demo, "STAGES", killed)
    b_before = _digest(folder / "b")
    assert main(["demo", "--out", str(folder), "--no-progress"]) == 128 + signal.SIGTERM
    line = _one_error_line_from_text(capsys.readouterr().err)
    assert "terminated by SIGTERM: stage 'b' published nothing" in line
    assert "were rewritten" in line and _digest(folder / "b") == b_before
    md = (folder / "report.md").read_text()
    assert "Interrupted this time" in md and "stage b ran" in md
    # Ctrl-C still exits 130 after a SIGTERM in an earlier command of this process
    monkeypatch.setattr(demo, "STAGES", _stub_stages(calls, interrupt=True))
    assert main(["demo", "--out", str(folder), "--only", "b", "--no-progress"]) == 130
    assert "interrupted: stage 'b'" in capsys.readouterr().err
