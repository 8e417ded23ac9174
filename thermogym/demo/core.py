"""The stage framework of ``thermogym demo``: context, results, staging, runner.

Guarantees
----------
* **A failing stage does not stop the demo.** Its error is recorded (the
  traceback goes to ``logs/<stage>.txt``), the report says so, and the
  following stages run; those that need its products are *skipped* with the
  reason.
* **Nothing half-written.** A stage writes into its own staging folder
  (``<out>/.staging-<pid>/<stage>/``); only when it finishes are its files
  moved into ``<out>`` (one ``os.replace`` per file, same file system). A
  failed or interrupted stage's staging folder is deleted. ``manifest.json``
  lists which stage wrote which file and when it ran; files an earlier run of
  a stage left and this run did not write again are removed, so every listed
  file belongs to the run the manifest names. The reports are written
  atomically at the end.
* **A stage not run leaves its earlier files alone.** With ``--only``, the
  stages not selected, and a stage skipped for want of its inputs, keep their
  files, their manifest entry and their report section (marked with when they
  ran). A selected stage reuses the products of earlier stages from the files
  of an earlier run in the same folder (same seed and mode), through the
  earlier stage's ``load`` function.
* **Ctrl-C** ends the running stage without publishing anything of it; the
  manifest and the reports are written for what finished (the rest keeps its
  earlier entries), then :class:`KeyboardInterrupt` propagates.
* **Deterministic for a seed.** Stages take every random draw from
  ``ctx.seed`` (offsets per use).
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import shutil
import sys
import time
import traceback
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from tqdm.auto import tqdm

from thermogym import __version__
from thermogym._fileio import atomic_write_text
from thermogym.errors import ConfigError

__all__ = [
    "DemoContext",
    "Stage",
    "StageResult",
    "StageSkipped",
    "Table",
    "run_stages",
]

T = TypeVar("T")

MANIFEST = "manifest.json"


@dataclass
class Table:
    """A table of the report (rendered as Markdown and as HTML).

    Attributes
    ----------
    header : list of str
    rows : list of list
        Cells; floats are shown with 4 significant digits.
    caption : str
    """

    header: list[str]
    rows: list[list[Any]]
    caption: str = ""


@dataclass
class StageResult:
    """What one stage produced.

    Attributes
    ----------
    key, title : str
    status : {"ok", "failed", "skipped"}
    seconds : float
        Wall time [s].
    shows : str
        One or two sentences: what the stage demonstrates.
    text : str
        Findings (a small Markdown subset: paragraphs, ``* `` lists, ```code```).
    tables : list of Table
    figures : list of (str, str)
        (path relative to the output folder, caption).
    files : list of str
        Files the stage wrote (relative to the output folder).
    highlights : dict
        Key numbers for the summary at the top of the report.
    error : str or None
    ran_at : str
        When the stage ran (ISO 8601, local time).
    carried : bool
        The section is an earlier run's, kept because the stage did not run
        (or was skipped) this time; ``note`` says why.
    note : str
    """

    key: str
    title: str
    status: str = "ok"
    seconds: float = 0.0
    shows: str = ""
    text: str = ""
    tables: list[Table] = field(default_factory=list)
    figures: list[tuple[str, str]] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
    highlights: dict[str, str] = field(default_factory=dict)
    error: str | None = None
    ran_at: str = ""
    carried: bool = False
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        """The section as JSON-ready data (``report.json``)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> StageResult:
        """Inverse of :meth:`to_dict`."""
        known = set(cls.__dataclass_fields__)
        kw = {k: v for k, v in d.items() if k in known}
        kw["tables"] = [Table(**t) for t in kw.get("tables", [])]
        kw["figures"] = [tuple(f) for f in kw.get("figures", [])]
        return cls(**kw)

    def table(self, header: list[str], rows: list[list[Any]], caption: str = "") -> None:
        """Add a table."""
        self.tables.append(Table(list(header), [list(r) for r in rows], caption))

    def figure(self, path: str, caption: str) -> None:
        """Add a figure (``path`` relative to the output folder)."""
        self.figures.append((path, caption))


class StageSkipped(Exception):
    """Raised by a stage whose inputs are missing."""


class DemoInterrupted(KeyboardInterrupt):
    """Ctrl-C during a demo run: what was and was not written (a ``KeyboardInterrupt``).

    Attributes
    ----------
    stage : str
        Key of the interrupted stage (it published nothing).
    finished : list of str
        Stages of this run that finished before it (their files were replaced).
    reports : bool
        Whether the reports were rewritten (only when a stage finished).
    """

    def __init__(self, stage: str, finished: list[str], reports: bool) -> None:
        super().__init__(stage)
        self.stage, self.finished, self.reports = stage, finished, reports


@dataclass
class DemoContext:
    """Shared state of a demo run.

    Attributes
    ----------
    out : Path
        Final output folder.
    quick : bool
        Smaller experiments (tests).
    seed : int
    progress : bool
        Show tqdm bars inside stages.
    products : dict
        What stages hand to later stages (recordings, FitResults, ...).
    """

    out: Path
    quick: bool = False
    seed: int = 0
    progress: bool = True
    products: dict[str, Any] = field(default_factory=dict)
    _stage_dir: Path | None = None
    #: key -> function that computes a product on first need (reused earlier outputs)
    lazy: dict[str, Callable[[], Any]] = field(default_factory=dict)

    # ------------------------------------------------------------------ paths
    @property
    def stage_dir(self) -> Path:
        """Staging folder of the running stage (its files move to ``out`` on success)."""
        if self._stage_dir is None:
            raise ConfigError("no stage is running: stage files are written inside a stage")
        return self._stage_dir

    def path(self, *parts: str) -> Path:
        """A path under the running stage's staging folder, its parent created."""
        p = self.stage_dir.joinpath(*parts)
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def rel(self, p: str | os.PathLike[str]) -> str:
        """``p`` (staged or final) relative to the output folder, with ``/``."""
        p = Path(p)
        for base in (self._stage_dir, self.out):
            if base is not None:
                try:
                    return p.relative_to(base).as_posix()
                except ValueError:
                    continue
        raise ConfigError(f"{str(p)!r} is not under the output folder {str(self.out)!r}")

    def final(self, p: str | os.PathLike[str]) -> Path:
        """Where a staged file will be once its stage has finished."""
        return self.out / self.rel(p)

    # ------------------------------------------------------------------ helpers
    def need(self, *keys: str) -> None:
        """Raise :class:`StageSkipped` if an earlier stage did not produce ``keys``."""
        for k in keys:
            if k not in self.products and k in self.lazy:
                self.products[k] = self.lazy.pop(k)()
        missing = [k for k in keys if k not in self.products]
        if missing:
            why = "; ".join(f"{k}: {v}" for k, v in self.products.get("_reuse_errors", {}).items())
            raise StageSkipped(
                f"needs {missing} from an earlier stage that did not finish"
                + (f" (earlier outputs not reused: {why})" if why else "")
            )

    @property
    def bars(self) -> bool:
        """Whether stages draw progress bars: progress on and stderr a terminal.

        Pass this (not :attr:`progress`) to library functions that take
        ``progress=`` for a bar, so that piped output gets no cursor codes.
        """
        return bool(self.progress and getattr(sys.stderr, "isatty", lambda: False)())

    def bar(self, items: Iterable[T], desc: str, total: int | None = None) -> Iterator[T]:
        """Iterate with a tqdm bar on stderr when progress is on and stderr is a terminal."""
        if not self.bars:
            yield from items  # no cursor codes in pipes and logs
            return
        with tqdm(items, desc=f"      {desc}", total=total, leave=False, file=sys.stderr) as it:
            yield from it


@dataclass(frozen=True)
class Stage:
    """A step of the demo.

    Attributes
    ----------
    key : str
        Short name (``--only KEY``).
    title : str
    run : callable
        ``run(ctx, result)``; fills ``result``, writes files through ``ctx.path``.
    load : callable, optional
        ``load(ctx)``: rebuild the stage's products from the files an earlier
        run wrote under ``ctx.out`` (``--only`` of a later stage); raises
        :class:`StageSkipped` when they are not there.
    """

    key: str
    title: str
    run: Callable[[DemoContext, StageResult], None]
    load: Callable[[DemoContext], None] | None = None


# --------------------------------------------------------------------------- manifest
def _read_manifest(out: Path) -> dict[str, Any]:
    try:
        doc = json.loads((out / MANIFEST).read_text())
        return doc if isinstance(doc, dict) and isinstance(doc.get("stages"), dict) else {}
    except (OSError, ValueError):
        return {}


def _publish(staging: Path, out: Path) -> list[str]:
    """Move every file of ``staging`` to the same place under ``out``; the moved paths."""
    moved = []
    for src in sorted(p for p in staging.rglob("*") if p.is_file() or p.is_symlink()):
        rel = src.relative_to(staging)
        dst = out / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        if dst.is_dir() and not dst.is_symlink():
            shutil.rmtree(dst)
        os.replace(src, dst)
        moved.append(rel.as_posix())
    return moved


def _remove_stale(out: Path, old: Sequence[str], keep: set[str]) -> None:
    """Delete files an earlier run of a stage wrote that this run did not write again."""
    for rel in old:
        if rel in keep or rel.startswith(("..", "/")):
            continue
        p = out / rel
        if p.is_file():
            p.unlink()
            # prune folders left empty, up to the output folder
            d = p.parent
            while d != out and d.is_dir() and not any(d.iterdir()):
                d.rmdir()
                d = d.parent


# --------------------------------------------------------------------------- runner
def _now() -> str:
    return _dt.datetime.now().astimezone().isoformat(timespec="seconds")


def _reuse_earlier(
    ctx: DemoContext,
    todo: Sequence[Stage],
    others: Sequence[Stage],
    old: dict[str, dict[str, Any]],
) -> list[str]:
    """Load the products of stages not run from an earlier run's files; what was reused."""
    if not todo:
        return []
    order = [s.key for s in others]
    last = max(order.index(s.key) for s in todo if s.key in order) if order else -1
    selected = {s.key for s in todo}
    reused = []
    for stage in others[:last]:
        entry = old.get(stage.key, {})
        if stage.key in selected or stage.load is None or entry.get("status") != "ok":
            continue
        if "seed" in entry or "quick" in entry:  # another seed or mode than this run's
            ctx.products.setdefault("_reuse_errors", {})[stage.key] = (
                f"the earlier {stage.key!r} outputs are from seed {entry.get('seed')}"
                f"{', quick mode' if entry.get('quick') else ''}"
            )
            continue
        try:
            stage.load(ctx)
        except (StageSkipped, OSError, ValueError, KeyError) as e:
            ctx.products.setdefault("_reuse_errors", {})[stage.key] = str(e)
            continue
        reused.append(stage.key)
    return reused


def run_stages(
    ctx: DemoContext,
    stages: Sequence[Stage],
    *,
    progress: bool = True,
    all_stages: Sequence[Stage] | None = None,
) -> list[StageResult]:
    """Run ``stages`` in order with the guarantees of the module docstring.

    Parameters
    ----------
    ctx : DemoContext
    stages : sequence of Stage
    progress : bool
        Print a line per stage (start and outcome).
    all_stages : sequence of Stage, optional
        Every stage of the demo in order; those not in ``stages`` that come
        before a selected one lend their earlier products (``Stage.load``).

    Returns
    -------
    list of StageResult
        One per stage run; a stage interrupted by Ctrl-C has status
        ``"interrupted"`` and is the last one (``KeyboardInterrupt`` is raised
        again by the caller after the reports are written).
    """
    ctx.out.mkdir(parents=True, exist_ok=True)
    for stale in ctx.out.glob(".staging-*"):  # left by a run that was killed
        shutil.rmtree(stale, ignore_errors=True)
    staging_root = ctx.out / f".staging-{os.getpid()}"
    old_doc = _read_manifest(ctx.out)
    old = {
        k: {"seed": old_doc.get("seed"), "quick": old_doc.get("quick"), **v}
        for k, v in old_doc.get("stages", {}).items()
        if isinstance(v, dict)
    }
    for v in old.values():  # each entry names its own seed and mode when they differ
        if v["seed"] == ctx.seed and v["quick"] == ctx.quick:
            del v["seed"], v["quick"]
    reused = _reuse_earlier(ctx, stages, list(all_stages or []), old)
    if progress and reused:
        print(f"reusing the outputs of earlier stage(s) {reused} in {ctx.out}", flush=True)
    manifest: dict[str, Any] = dict(old)
    results: list[StageResult] = []
    try:
        for i, stage in enumerate(stages, 1):
            res = StageResult(stage.key, stage.title, ran_at=_now())
            if progress:
                print(f"[{i}/{len(stages)}] {stage.title} ...", flush=True)
            ctx._stage_dir = staging_root / stage.key
            shutil.rmtree(ctx._stage_dir, ignore_errors=True)
            ctx._stage_dir.mkdir(parents=True)
            t0 = time.perf_counter()
            try:
                stage.run(ctx, res)
                res.files = _publish(ctx._stage_dir, ctx.out)
            except StageSkipped as e:
                res.status, res.error = "skipped", str(e)
            except KeyboardInterrupt:
                res.status, res.error = (
                    "interrupted",
                    "interrupted (Ctrl-C, SIGTERM); nothing published",
                )
                res.seconds = time.perf_counter() - t0
                res.figures, res.files = [], []
                results.append(res)
                break
            except Exception as e:
                res.status = "failed"
                res.error = f"{type(e).__name__}: {e}"
                log = ctx.out / "logs" / f"{stage.key}.txt"
                log.parent.mkdir(parents=True, exist_ok=True)
                atomic_write_text(log, traceback.format_exc())
            finally:
                shutil.rmtree(ctx._stage_dir, ignore_errors=True)
                ctx._stage_dir = None
            res.seconds = time.perf_counter() - t0
            if res.status != "ok":
                # a stage that did not finish claims no files (its figures were staged only)
                res.figures, res.files = [], []
            if res.status == "skipped" and stage.key in old:
                # not run: its earlier files, manifest entry and section stay as they were
                manifest[stage.key] = {
                    **old[stage.key],
                    "skipped_at": res.ran_at,
                    "skipped": res.error,
                }
            else:
                _remove_stale(ctx.out, old.get(stage.key, {}).get("files", []), set(res.files))
                if res.status != "failed":
                    stale_log = ctx.out / "logs" / f"{stage.key}.txt"
                    if stale_log.is_file():
                        stale_log.unlink()
                manifest[stage.key] = {
                    "status": res.status,
                    "files": res.files,
                    "ran_at": res.ran_at,
                }
            if progress:
                print(
                    f"      {res.status} in {res.seconds:.1f} s"
                    + (f": {res.error}" if res.error else ""),
                    flush=True,
                )
            results.append(res)
    finally:
        shutil.rmtree(staging_root, ignore_errors=True)
        ctx._stage_dir = None
        atomic_write_text(
            ctx.out / MANIFEST,
            json.dumps(
                {
                    "package_version": __version__,
                    "seed": ctx.seed,
                    "quick": ctx.quick,
                    "stages": manifest,
                },
                indent=2,
            )
            + "\n",
        )
    return results
