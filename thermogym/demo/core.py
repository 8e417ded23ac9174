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
  failed stage's staging folder is deleted. ``manifest.json`` lists which
  stage wrote which file; files an earlier run of a stage left and this run
  did not write again are removed, so every listed file belongs to this run.
  The reports are written atomically at the end.
* **Deterministic for a seed.** Stages take every random draw from
  ``ctx.seed`` (offsets per use).
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import time
import traceback
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

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

    def table(self, header: list[str], rows: list[list[Any]], caption: str = "") -> None:
        """Add a table."""
        self.tables.append(Table(list(header), [list(r) for r in rows], caption))

    def figure(self, path: str, caption: str) -> None:
        """Add a figure (``path`` relative to the output folder)."""
        self.figures.append((path, caption))


class StageSkipped(Exception):
    """Raised by a stage whose inputs are missing."""


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
        missing = [k for k in keys if k not in self.products]
        if missing:
            raise StageSkipped(f"needs {missing} from an earlier stage that did not finish")

    def bar(self, items: Iterable[T], desc: str, total: int | None = None) -> Iterator[T]:
        """Iterate with a tqdm bar on stderr when progress is on."""
        if not self.progress:
            yield from items
            return
        from tqdm.auto import tqdm

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
    """

    key: str
    title: str
    run: Callable[[DemoContext, StageResult], None]


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
def run_stages(
    ctx: DemoContext,
    stages: Sequence[Stage],
    *,
    progress: bool = True,
) -> list[StageResult]:
    """Run ``stages`` in order with the guarantees of the module docstring.

    Parameters
    ----------
    ctx : DemoContext
    stages : sequence of Stage
    progress : bool
        Print a line per stage (start and outcome).

    Returns
    -------
    list of StageResult
    """
    ctx.out.mkdir(parents=True, exist_ok=True)
    for stale in ctx.out.glob(".staging-*"):  # left by a run that was killed
        shutil.rmtree(stale, ignore_errors=True)
    staging_root = ctx.out / f".staging-{os.getpid()}"
    old = _read_manifest(ctx.out).get("stages", {})
    manifest: dict[str, Any] = {k: v for k, v in old.items() if k not in {s.key for s in stages}}
    results: list[StageResult] = []
    try:
        for i, stage in enumerate(stages, 1):
            res = StageResult(stage.key, stage.title)
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
            _remove_stale(ctx.out, old.get(stage.key, {}).get("files", []), set(res.files))
            if res.status != "failed":
                stale_log = ctx.out / "logs" / f"{stage.key}.txt"
                if stale_log.is_file():
                    stale_log.unlink()
            manifest[stage.key] = {"status": res.status, "files": res.files}
            if progress:
                print(
                    f"      {res.status} in {res.seconds:.1f} s"
                    + (f": {res.error}" if res.error else ""),
                    flush=True,
                )
            results.append(res)
    finally:
        shutil.rmtree(staging_root, ignore_errors=True)
        atomic_write_text(
            ctx.out / MANIFEST,
            json.dumps(
                {"package_version": __version__, "seed": ctx.seed, "stages": manifest}, indent=2
            )
            + "\n",
        )
    return results
