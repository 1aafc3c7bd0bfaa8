"""Regenerate the figures under docs/figures/ (README and docs/usage.md show them).

    .venv/bin/python docs/make_figures.py

``shoulder_backlash_run.png``: the 2 kg pick-and-place with 0.1 deg of backlash in the shoulder against its
healthy twin (same noise seed), drawn by :func:`ur5fault.plotting.run_figure` exactly as in the notebook
example of docs/usage.md.  About 20 s on one core.
"""

from __future__ import annotations

from pathlib import Path

from ur5fault import RunSpec, Simulator, make_effect, pick_and_place
from ur5fault.plotting import run_figure

FIGURES = Path(__file__).resolve().parent / "figures"
#: resolution of the committed PNG files [dots per inch]: small files, still legible on GitHub
DPI = 72


def shoulder_backlash_run(path: Path) -> Path:
    runs = [RunSpec("healthy", seed=0),
            RunSpec("worn", seed=0, effects=(make_effect("backlash", "shoulder_lift_joint", backlash_deg=0.1),))]
    res = Simulator().run(pick_and_place(), runs)
    fig = run_figure(res.to_pandas("worn"), twin=res.to_pandas("healthy"),
                     title="0.1 deg backlash in the shoulder, 2 kg pick-and-place (ur5fault show)")
    fig.savefig(path, dpi=DPI)
    return path


if __name__ == "__main__":
    FIGURES.mkdir(exist_ok=True)
    print(f"wrote {shoulder_backlash_run(FIGURES / 'shoulder_backlash_run.png')}")
