"""The `biovln-ms` command line: the root app (``app``), its plugin option, `biovln-ms list` and the entry
point (``main``), which prints a user's error as one line. Each command group is a module of this package;
a command imports its code when it runs, so `biovln-ms --help` stays fast."""

from __future__ import annotations

import sys

import typer
from rich.console import Console
from rich.markup import escape

from biovln_ms.errors import BioVLNError
from biovln_ms.eval.methods import report_methods
from biovln_ms.plugins import load_plugins

# the command modules register their commands on import, in the order `biovln-ms --help` lists them
from biovln_ms.cli import info, assets, scene, dataset, evaluate, lsat, train, export, perception  # noqa: F401
from biovln_ms.cli.common import _method_line, _methods_help, app  # noqa: F401 (_methods_help: re-exported)
from biovln_ms.cli.evaluate import _record_index  # noqa: F401 (re-exported)

console = Console(stderr=True)


#: what a user can cause and fix: printed as one line, exit status 2
USER_ERRORS = (BioVLNError, OSError)


def user_error_line(e: BaseException) -> str:
    """The one line a user error prints: a BioVLNError as it says; a file the command could not read or
    write (too long a name, no permission, a missing folder) with the path and the system's reason."""
    if isinstance(e, OSError):
        where = e.filename if e.filename is not None else "a file"
        return f"{where}: {e.strerror or e} (fix: check the path, its folder and its permissions)"
    return str(e)


@app.callback()
def _plugins(
    plugin: list[str] = typer.Option(
        [],
        "--plugin",
        help="A plugin module (or .py file) to import first: your methods, measures, sensors, variants, "
        "templates and instruments (repeatable; entry points of the group biovln_ms.plugins load always).",
    ),
) -> None:
    load_plugins(plugin)


def _plugin_args(argv: list[str]) -> list[str]:
    """The ``--plugin`` values before the command (loaded before the commands read the registries)."""
    out = []
    for i, arg in enumerate(argv):
        if arg == "--plugin" and i + 1 < len(argv):
            out.append(argv[i + 1])
        elif arg.startswith("--plugin="):
            out.append(arg.split("=", 1)[1])
    return out


@app.command("list")
def list_cmd(
    what: str = typer.Argument(
        "methods", help="methods, variants, measures, sensors, templates or instruments."
    ),
) -> None:
    """List what is registered.

    Methods, env variants, measures (with their record key), sensors, scene templates or instruments."""
    from biovln_ms.catalog import load_catalog
    from biovln_ms.metrics.measures import measure_names, measure_type
    from biovln_ms.scene.templates import template_names
    from biovln_ms.variants import VARIANTS

    if what == "sensors":
        from biovln_ms.tasks.sensors import SENSORS  # the simulator layer: sapien, torch

        rows = list(SENSORS)
    else:
        rows = {
            "methods": lambda: [_method_line(m) for m in report_methods()],
            "variants": lambda: list(VARIANTS),
            "measures": lambda: [
                n + (f" -> {measure_type(n).metric.key}" if measure_type(n).metric else "")
                for n in measure_names()
            ],
            "templates": template_names,
            "instruments": lambda: load_catalog().names(),
        }.get(what, lambda: None)()
    if rows is None:
        raise BioVLNError(
            f"nothing called '{what}' is listed",
            field="what",
            fix="use methods, variants, measures, sensors, templates or instruments",
        )
    for row in rows:
        typer.echo(row)


def main() -> None:
    """Entry point: user-facing errors print as one clear line, not a traceback."""
    try:
        load_plugins(_plugin_args(sys.argv[1:]))
        app()
    except USER_ERRORS as e:
        console.print(f"[bold red]error:[/] {escape(user_error_line(e))}", highlight=False, soft_wrap=True)
        sys.exit(2)
