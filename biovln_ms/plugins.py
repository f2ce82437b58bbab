"""Your code, registered without editing the package: plugin modules.

A plugin is any importable module (or a ``.py`` file) that registers things when imported: a measure
(``register_measure``), a sensor (``register_sensor``), a method (``register_method``), a variant
(``register_variant``), a scene template (``register_template``), instruments (a catalog overlay and an
``@instrument`` builder). Load one with ``biovln-ms --plugin my_module ...``, ``load_plugins(["my_module"])``,
or install it under the entry-point group ``biovln_ms.plugins`` (loaded by the CLI and by evaluation
workers). Evaluation hands its workers the plugins loaded in the driver, so spawned processes register
the same things (``EvalConfig.plugins``).
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from importlib import metadata
from pathlib import Path

from biovln_ms.errors import BioVLNError

ENTRY_POINT_GROUP = "biovln_ms.plugins"
_LOADED: list[str] = []


class PluginError(BioVLNError):
    """A plugin that cannot be imported."""


def _import(name: str) -> None:
    if name.endswith(".py"):
        path = Path(name).resolve()
        if not path.is_file():
            raise PluginError(
                f"no plugin file {path}", field="plugin", fix="pass an existing .py file or a module"
            )
        spec = importlib.util.spec_from_file_location(f"biovln_plugin_{path.stem}", path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module
        spec.loader.exec_module(module)
    else:
        importlib.import_module(name)


def load_plugins(names: list[str] | tuple[str, ...] = (), entry_points: bool = True) -> list[str]:
    """Import the plugin modules ``names`` (module names or ``.py`` paths) and, with ``entry_points``, every
    module of the ``biovln_ms.plugins`` entry-point group, once each; the names loaded so far."""
    wanted = list(names)
    if entry_points:
        wanted += [ep.module for ep in metadata.entry_points(group=ENTRY_POINT_GROUP)]
    for name in wanted:
        if name in _LOADED:
            continue
        try:
            _import(name)
        except BioVLNError:
            raise
        except Exception as e:  # the user's module: whatever it raises is reported in one line
            raise PluginError(
                f"cannot load plugin '{name}': {type(e).__name__}: {e}",
                field="plugin",
                fix="check that it imports on its own (python -c 'import <module>') and is on sys.path",
            ) from None
        _LOADED.append(name)
    return list(_LOADED)


def loaded_plugins() -> list[str]:
    """The plugins imported so far (in this process), in order."""
    return list(_LOADED)
