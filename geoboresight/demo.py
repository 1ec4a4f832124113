"""``make demo``: the main job on the bundled sample scene, step by step, into one folder.

Run ``python -m geoboresight.demo --out out``. Each step is an ordinary algorithm spec run
through :func:`geoboresight.algorithms.execute`, exactly as the CLI or QGIS would run it, so
the demo doubles as a worked example (the equivalent ``geoboresight`` commands are printed).
"""

from __future__ import annotations

import os
import shutil
import sys
import time
from pathlib import Path

import click

from .algorithms import execute, registry
from .errors import GeoboresightError
from .progress import Progress

SAMPLE = Path(__file__).resolve().parents[1] / "sample_data" / "scene"


def _scene(out: Path, scene: str | None) -> Path:
    if scene:
        return Path(scene)
    if (SAMPLE / "vnir.hdr").exists():
        return SAMPLE
    # Not a source checkout (or no sample yet): simulate a small scene with the same recipe.
    target = out / "scene"
    if not (target / "vnir.hdr").exists():
        click.echo(f"no bundled sample scene found; simulating one into {target}")
        execute(
            registry()["simulate"],
            # the recipe of sample_data/README.md
            {
                "preset": "mixed",
                "lines": 192,
                "seed": 4,
                "geometry": "large-squint",
                "clouds": 1,
                "output": str(target),
            },
            overwrite=True,
        )
    return target


def steps(scene: Path, out: Path) -> list[tuple[str, dict]]:
    """The demo's steps: (algorithm name, values). Steps whose algorithm is absent are skipped."""
    v, s = str(scene / "vnir.hdr"), str(scene / "swir.hdr")
    ratio = str(out / "boresight_ratio.tif")
    return [
        ("ratio", {"vnir": v, "swir": s, "output": ratio}),
        (
            "stats",
            {
                "input": ratio,
                "output": str(out / "ratio_stats.json"),
                "html": str(out / "ratio_stats.html"),
                "histogram": str(out / "ratio_histogram.png"),
            },
        ),
    ]


def _command_line(name: str, values: dict) -> str:
    parts = ["geoboresight", name]
    for k, val in values.items():
        if isinstance(val, bool):
            parts.append(f"--{k.replace('_', '-')}" if val else f"--no-{k.replace('_', '-')}")
        else:
            parts += [f"--{k.replace('_', '-')}", str(val)]
    return " ".join(parts)


@click.command()
@click.option(
    "--out", default="out", show_default=True, help="Folder for the demo's outputs (replaced)."
)
@click.option(
    "--scene",
    default=None,
    help="Scene folder (vnir.hdr, swir.hdr, truth_*); default: sample_data/.",
)
def main(out: str, scene: str | None) -> None:
    """Run the boresight products on the sample scene and list what was written."""
    out_dir = Path(out)
    if out_dir.exists():
        shutil.rmtree(out_dir)
    out_dir.mkdir(parents=True)
    scene_dir = _scene(out_dir, scene)
    click.echo(f"scene: {scene_dir}")
    algs = registry()
    for name, values in steps(scene_dir, out_dir):
        if name not in algs:
            click.echo(f"-- {name}: not available in this version, skipped")
            continue
        click.echo(f"\n$ {_command_line(name, values)}")
        t0 = time.perf_counter()
        with click.progressbar(length=1000, label=algs[name].display_name, file=sys.stderr) as bar:
            done = [0]

            def cb(f, _m, bar=bar, done=done):
                step = int(f * 1000) - done[0]
                if step > 0:
                    bar.update(step)
                    done[0] += step

            try:
                result = execute(algs[name], values, progress=Progress(cb), overwrite=True)
            except GeoboresightError as exc:
                raise click.ClickException(f"{name}: {exc}") from None
        for k, val in result.items():
            click.echo(f"   {k}: {val}")
        click.echo(f"   ({time.perf_counter() - t0:.1f} s)")
    click.echo(f"\nOutputs in {os.path.abspath(out_dir)}:")
    for p in sorted(out_dir.rglob("*")):
        if p.is_file() and not p.name.startswith("."):
            click.echo(f"  {p.relative_to(out_dir)}  ({p.stat().st_size / 1024:.0f} KiB)")


if __name__ == "__main__":  # pragma: no cover
    main()
