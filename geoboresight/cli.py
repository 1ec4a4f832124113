"""The ``geoboresight`` command line, generated from the algorithm specs.

Every spec becomes a subcommand whose options are its parameters (``--numerator-nm 1010``;
the output named ``output`` is also ``-o``). The same commands are mounted under
``rio boresight`` (see :mod:`geoboresight.rio`). No science here: values go to
:func:`geoboresight.algorithms.execute`.
"""

from __future__ import annotations

import json
import os
import sys

import click

from . import __version__
from .algorithms import find, registry
from .algorithms.spec import Algorithm, Param, execute
from .errors import Cancelled, GeoboresightError, cli_option, worded
from .progress import Progress

_CLICK_TYPES = {
    # A folder too: a sensor product delivered as a folder (EnMAP L1B, io.products).
    "raster": click.Path(),
    "multiraster": click.STRING,
    "file": click.Path(dir_okay=False),
    "band": click.INT,
    "string": click.STRING,
    "raster_out": click.Path(dir_okay=False),
    "vector_out": click.Path(dir_okay=False),
    "file_out": click.Path(dir_okay=False),
    "folder_out": click.Path(file_okay=False),
}


def option_name(p: Param) -> str:
    return "--" + p.name.replace("_", "-")


def _number(v) -> str:
    """A range end as people read it: 2147483647, 5000000, 0.5 (not 2.14748e+09)."""
    return str(int(v)) if float(v).is_integer() and abs(v) < 1e15 else f"{v:g}"


def _help_for(p: Param) -> str:
    text = p.description
    bits = []
    if p.kind in ("number", "wavelength"):
        lo, hi = p.minimum, p.maximum
        span = f"{_number(lo)}–{_number(hi)}" if lo is not None and hi is not None else ""
        if span and span not in text:  # "(0–1) [0–1]": the description says it already
            bits.append(f"{span}{(' ' + p.unit) if p.unit else ''}")
    if p.kind == "band":
        bits.append(f"band of --{p.raster.replace('_', '-')}")
    if p.kind == "multiraster":
        bits.append("repeat the option or separate paths with commas")
    if p.kind == "numbers" and p.names:
        bits.append(" ".join(p.names) + (f" ({p.unit})" if p.unit else ""))
    return text + (f" [{'; '.join(bits)}]" if bits else "")


def _option(p: Param) -> click.Option:
    decls = [option_name(p)]
    if p.name == "output":
        decls.insert(0, "-o")
    if p.name == "input":
        decls.insert(0, "-i")
    kwargs = {
        "help": _help_for(p),
        # A parameter with a former name may come under that name: execute() names it if
        # neither was given.
        "required": p.required and not p.aliases,
        "show_default": p.default not in (None, False),
    }
    if p.kind == "bool":
        flag = p.name.replace("_", "-")
        return click.Option(
            [f"--{flag}/--no-{flag}"],
            default=bool(p.default),
            help=p.description,
            show_default=True,
        )
    if p.kind == "enum":
        kwargs["type"] = click.Choice(p.choices)
    elif p.kind in ("number", "wavelength"):
        kwargs["type"] = click.INT if p.integer else click.FLOAT
    elif p.kind == "numbers":
        # three values after one option, as rio's --bounds: negative values work as written
        kwargs["type"] = click.FLOAT
        kwargs["nargs"] = p.count
        if p.names:
            kwargs["metavar"] = " ".join(p.names)
    else:
        kwargs["type"] = _CLICK_TYPES.get(p.kind, click.STRING)
    if p.kind == "multiraster":
        kwargs["multiple"] = True
        kwargs["required"] = False
    if p.default is not None:  # click >= 8.2 treats an explicit default=None as a value
        kwargs["default"] = p.default
    return click.Option(decls, **kwargs)


def _alias_options(p: Param) -> list[click.Option]:
    """Hidden options for a parameter's former names (kept for one release)."""
    out = []
    for alias in p.aliases:
        kwargs = {"hidden": True, "default": None, "help": f"Former name of {option_name(p)}."}
        if p.kind in ("number", "wavelength"):
            kwargs["type"] = click.INT if p.integer else click.FLOAT
        out.append(click.Option(["--" + alias.replace("_", "-"), alias], **kwargs))
    return out


class _Bar:
    """A click progress bar fed by Progress callbacks (silent when stderr is not a terminal)."""

    def __init__(self, label: str, quiet: bool):
        self.quiet = quiet
        self.label = label
        self.bar = None
        self.done = 0

    def __call__(self, fraction: float, message: str | None) -> None:
        if self.quiet:
            return
        if self.bar is None:
            self.bar = click.progressbar(length=1000, label=self.label, file=sys.stderr)
            self.bar.__enter__()
        step = int(fraction * 1000) - self.done
        if step > 0:
            self.bar.update(step)
            self.done += step

    def log(self, message: str) -> None:
        """A log line on a line of its own: the bar (drawn without a newline) is ended first
        and drawn again below on its next update."""
        if self.bar is not None and not getattr(self.bar, "hidden", True) and self.done:
            click.echo("", err=True)
        click.echo(message, err=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.__exit__(None, None, None)


def paragraphs(text: str) -> str:
    """A spec's help for click: a paragraph of bullets ("• ...") or a list kept as written
    (click's ``\\b`` marker), other paragraphs rewrapped to the terminal."""
    out = []
    for para in text.split("\n\n"):
        lines = para.split("\n")
        if any(line.lstrip().startswith(("•", "- ")) for line in lines[1:]):
            para = "\b\n" + para
        out.append(para)
    return "\n\n".join(out)


def make_command(alg: Algorithm) -> click.Command:
    """A click command for ``alg``: options from its parameters, the run through ``execute``."""

    def callback(
        overwrite: bool,
        quiet: bool,
        as_json: bool,
        debug: bool = False,
        cog: bool = False,
        co: tuple = (),
        raw_gsd: float | None = None,
        **raw,
    ):
        args = raw.pop("positional_args", ()) or ()
        if len(args) > len(alg.positional):
            raise click.UsageError(f"at most {len(alg.positional)} path(s) as arguments")
        for name, value in zip(alg.positional, args, strict=False):
            if raw.get(name) is not None:
                raise click.UsageError(f"{name} given twice: as an argument and as --{name}")
            raw[name] = value
        values = {}
        for p in alg.params:
            v = raw.get(p.name)
            if p.kind == "multiraster":
                v = list(v) or None
            for alias in p.aliases:
                if raw.get(alias) is not None:
                    if ctx_source(p.name) == "commandline":
                        raise click.UsageError(
                            f"give {option_name(p)} or its former name "
                            f"--{alias.replace('_', '-')}, not both"
                        )
                    v = raw[alias]
            values[p.name] = v
        bar = _Bar(alg.display_name, quiet)
        log = None if quiet else bar.log
        progress = Progress(bar, log=log)
        try:
            result = execute(
                alg,
                values,
                progress=progress,
                overwrite=overwrite,
                cog=cog,
                co=list(co),
                raw_gsd=raw_gsd,
            )
        except BaseException as exc:
            bar.close()
            raise failure(exc, debug) from None
        bar.close()
        if as_json:
            click.echo(json.dumps(result, indent=2, default=str))
        elif alg.text and isinstance(result.get(alg.text), str):
            click.echo(result[alg.text])
        else:
            for k, v in result.items():
                click.echo(f"{k}: {v}")

    def ctx_source(name: str):
        source = click.get_current_context().get_parameter_source(name)
        return source.name.lower() if source is not None else None

    params = [_option(p) for p in alg.params]
    if alg.positional:
        for o in params:
            if o.name in alg.positional:
                o.required = False  # execute() names it when missing
        params.insert(
            0,
            click.Argument(
                ["positional_args"],
                nargs=-1,
                type=click.Path(),
                metavar=" ".join(f"[{n.upper()}]" for n in alg.positional),
            ),
        )
    params += [o for p in alg.params for o in _alias_options(p)]
    params += [
        click.Option(
            ["--overwrite"],
            is_flag=True,
            help="Replace outputs that already exist (inputs are never overwritten).",
        ),
        click.Option(
            ["--cog"],
            is_flag=True,
            help="Write GeoTIFF outputs as Cloud-Optimised GeoTIFFs (GDAL's COG driver).",
        ),
        click.Option(
            ["--co", "co"],
            multiple=True,
            metavar="NAME=VALUE",
            help="GDAL creation option for GeoTIFF outputs (repeatable; e.g. --co COMPRESS=LZW).",
        ),
        click.Option(
            ["--raw-gsd", "raw_gsd"],
            type=float,
            metavar="METRES",
            help="Raw-geometry outputs: write a local engineering CRS in metres with this pixel "
            "size (no Earth position), so that a GIS measures metres instead of degrees.",
        ),
        click.Option(["-q", "--quiet"], is_flag=True, help="No progress bar or log messages."),
        click.Option(["--json", "as_json"], is_flag=True, help="Print the results as JSON."),
        click.Option(["--debug"], is_flag=True, help="Show the full traceback of an error."),
    ]
    return click.Command(
        name=alg.name,
        callback=callback,
        params=params,
        help=f"{alg.display_name}.\n\n{paragraphs(alg.help)}",
        short_help=alg.short_help,
        epilog=f"\b\nExample:\n  {alg.example_command()}" if alg.example else None,
        context_settings={"max_content_width": 100},
    )


class InternalError(click.ClickException):
    """An error that is not the user's: a bug to report (exit status 70, EX_SOFTWARE)."""

    exit_code = 70


def debugging(flag: bool = False) -> bool:
    """True when the user asked for tracebacks: ``--debug`` on the command or before it, or
    GEOBORESIGHT_DEBUG=1."""
    ctx = click.get_current_context(silent=True)
    root = ctx.find_root().params.get("debug") if ctx is not None else False
    return bool(flag or root or os.environ.get("GEOBORESIGHT_DEBUG", "") not in ("", "0"))


def failure(exc: BaseException, debug: bool = False) -> BaseException:
    """The one line the user sees for ``exc`` (never a traceback unless debugging): the
    message of a :class:`GeoboresightError`, "cancelled" for Ctrl-C, and for anything else
    (a bug) its type and message with a pointer to ``--debug``. Raises ``exc`` itself when
    debugging, so that its traceback is printed."""
    if debugging(debug) and not isinstance(exc, click.exceptions.Exit | click.ClickException):
        raise exc
    if isinstance(exc, KeyboardInterrupt | Cancelled):
        return click.ClickException("cancelled; no output was left behind")
    if isinstance(exc, click.ClickException | click.exceptions.Exit | click.Abort):
        return exc
    if isinstance(exc, GeoboresightError):
        # The parameters in the command line's own words: --vnir, --overwrite.
        return click.ClickException(worded(exc, cli_option))
    if not isinstance(exc, Exception):
        return exc  # SystemExit and the like pass through
    text = " ".join(str(exc).split()) or "no message"
    return InternalError(
        f"unexpected {type(exc).__name__}: {text}. This is a bug in geoboresight: run the "
        "command again with --debug for the traceback and report it"
    )


class SpecGroup(click.Group):
    """A click group whose subcommands are the registry's specs plus ``list``."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        """Click's main, with a usage error (unknown option, missing value) as one line that
        says where the help is, instead of the usage block before the error."""
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        try:
            rv = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click.UsageError as exc:
            top = prog_name or os.path.basename(sys.argv[0]) or self.name
            where = exc.ctx.command_path if exc.ctx is not None else top
            click.echo(f"Error: {exc.format_message()} (see '{where} --help')", err=True)
            sys.exit(exc.exit_code)
        except click.ClickException as exc:
            exc.show()
            sys.exit(exc.exit_code)
        except click.Abort:
            click.echo("Aborted!", err=True)
            sys.exit(1)
        sys.exit(rv if isinstance(rv, int) else 0)

    def list_commands(self, ctx):
        return ["list", "batch", "engine", *registry()]

    def get_command(self, ctx, name):
        if name == "list":
            return _list
        if name == "batch":
            return _batch
        if name == "engine":  # machine mode for front-ends (the QGIS plugin): geoboresight.engine
            from .engine import engine_command

            return engine_command()
        alg = find(name)  # imports this operation's spec module only (start-up time)
        return make_command(alg) if alg is not None else None


@click.command(name="list", short_help="List the operations, grouped as in the QGIS toolbox.")
def _list():
    """List the operations, grouped by the paper's applications."""
    group = None
    for alg in registry().values():
        if alg.group != group:
            group = alg.group
            click.echo(f"\n{group}")
        click.echo(f"  {alg.name:<22} {alg.short_help}")


@click.command(name="batch", short_help="Run one operation on many flight lines with Dask.")
@click.argument("operation")
@click.argument("jobs", type=click.Path(dir_okay=False))
@click.option(
    "--scheduler",
    default=None,
    help="Address of a dask.distributed scheduler (default: a local cluster).",
)
@click.option(
    "--workers",
    type=int,
    default=None,
    help="Worker processes of the local cluster (default: one per core).",
)
@click.option("--overwrite", is_flag=True, help="Replace outputs that already exist.")
def _batch(operation, jobs, scheduler, workers, overwrite):
    """Run OPERATION once per job listed in JOBS (a JSON list of objects, or a CSV whose header
    names the parameters, e.g. vnir,swir,output), in parallel on Dask.
    """
    from .batch import read_labelled_jobs, run_batch

    bar = _Bar(f"batch {operation}", quiet=False)
    try:
        values, labels = read_labelled_jobs(jobs)
        results = run_batch(
            operation,
            values,
            labels=labels,
            scheduler=scheduler,
            n_workers=workers,
            overwrite=overwrite,
            progress=Progress(bar, log=bar.log),
        )
    except BaseException as exc:
        bar.close()
        raise failure(exc) from None
    bar.close()
    failed = [r for r in results if not r.ok]
    for r in results:
        click.echo(
            f"{r.label or f'job {r.index + 1}'}: "
            + ("ok " + json.dumps(r.result, default=str) if r.ok else f"FAILED: {r.error}")
        )
    if failed:
        raise click.ClickException(f"{len(failed)} of {len(results)} jobs failed")


@click.group(
    name="geoboresight",
    cls=SpecGroup,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
)
@click.version_option(__version__, prog_name="geoboresight")
@click.option("--debug", is_flag=True, help="Show the full traceback of an error.")
def main(debug: bool = False):
    """geoboresight: the boresight effect of dual VNIR+SWIR pushbroom sensors as information.

    Brook & Ben-Dor (2011): the boresight band ratio b(1010 nm)/b(920 nm) and its statistics,
    a shadow map, a relative DEM and a sub-pixel anomaly indicator. Run `geoboresight list`
    for the operations and `geoboresight OPERATION --help` for one.
    """


if __name__ == "__main__":  # pragma: no cover
    main()
