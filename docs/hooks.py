"""MkDocs hook (``hooks:`` in mkdocs.yml): the figures in the docs come from the code and its data files,
never typed in. A page asks for one with a placeholder alone on its line:

- ``{{ table: benchmarks/env_speed }}``: a measured table, ``docs/data/benchmarks/env_speed.json``, as the
  benchmark script (or fuzz campaign) wrote it (``biovln_ms.measured``), with what measured it, where
  and when.
- ``{{ report: table5 }}``: one of ``biovln-ms report``'s tables (``biovln_ms.eval.report.TABLES``: table5,
  table10, table6, table9, table11, table17, mcnemar, differences), made by the report's own code from
  ``docs/data/reproduction.json`` (a copy of the report's ``measured.json``); the paper's numbers come
  from ``biovln_ms.eval.paper``. ``{{ report: source }}`` says where that file comes from.
- ``{{ catalog }}``: the instrument catalog, read from ``assets/catalog.json``.
- ``{{ metrics }}``: every recorded metric, from the measures' declarations (``Measure.metric``): record key,
  what is recorded, and each aggregate with its unit, episodes and interval (``single`` or ``protocol``).
- ``{{ protocols }}``: the shipped lab protocols (``biovln_ms/protocols/data/``), every step and its purpose.
- ``{{ dataset: splits }}``: scenes, episodes, categories and difficulty mix of each split of the default
  dataset, built by the code (about 4 s, cached like ``gym.make`` does).

An unknown placeholder or a missing data file fails the build. The API pages' Sphinx roles
(``:class:`~x.Y```) are shown as plain code.
"""

from __future__ import annotations

import json
import re
from functools import cache
from pathlib import Path

from mkdocs.exceptions import PluginError

DATA = Path(__file__).resolve().parent / "data"
PLACEHOLDER = re.compile(r"^\{\{ *(\w+)(?: *: *([\w/.-]+))? *\}\}[ \t]*$", re.MULTILINE)


def _table(name: str) -> str:
    from biovln_ms.measured import load_table, table_markdown

    path = DATA / f"{name}.json"
    if not path.is_file():
        raise PluginError(f"docs: no measured table {path} (run the script that writes it)")
    return table_markdown(load_table(path))


@cache
def _reproduction() -> dict:
    return json.loads((DATA / "reproduction.json").read_text())


def _report(name: str) -> str:
    from biovln_ms.eval.report import TABLES

    data = _reproduction()
    if name == "source":
        text = f"*Measured by `{data['command']}` on {data['machine']}, {data['written']}.*"
        return text + (f" {data['provenance']}" if data.get("provenance") else "")
    if name not in TABLES:
        raise PluginError(f"docs: no report table {name!r}; known: {', '.join(TABLES)}")
    lines = TABLES[name](data)
    # the report's section titles become the page's third-level headings
    return "\n".join("#" + line if line.startswith("## ") else line for line in lines)


def _catalog(_: str | None) -> str:
    from biovln_ms.catalog import load_catalog

    def show(v) -> str:
        return "–" if v is None else str(v)

    rows = [
        "| asset | dimensions (m) | placement | face | d_half (m) | δ (m) | r (m) | goal category | "
        "interaction point (model frame, m) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for a in load_catalog().assets():
        dims = " × ".join(f"{d:.2f}" for d in a.dimensions)
        point = (
            "–"
            if a.interaction is None
            else f"{a.interaction.label} ({', '.join(map(str, a.interaction.point))})"
        )
        rows.append(
            f"| `{a.name}` | {dims} | {a.placement} | {show(a.face)} | {show(a.d_half)} | "
            f"{show(a.approach_distance)} | {show(a.success_radius)} | {'yes' if a.goal_category else 'no'} "
            f"| {point} |"
        )
    return "\n".join(rows)


def _protocols(_: str | None) -> str:
    from biovln_ms.protocols import load_protocols

    def step(s) -> str:
        if s.any_order is None:
            return f"`{s.category}`: {s.purpose}"
        return "any order: " + "; ".join(f"`{v.category}`: {v.purpose}" for v in s.any_order)

    rows = ["| protocol | K | steps (in order) |", "|---|---|---|"]
    for p in load_protocols(env=False):
        steps = "<br>".join(f"{i}. {step(s)}" for i, s in enumerate(p.steps, 1))
        rows.append(f"| `{p.id}`<br>**{p.name}**<br>{p.description} | {p.k} | {steps} |")
    return "\n".join(rows)


def _dataset(name: str) -> str:
    if name != "splits":
        raise PluginError(f"docs: no dataset table {name!r}; known: splits")
    from biovln_ms.splits import ensure_default_dataset
    from biovln_ms.episodes.dataset import EpisodeDataset

    ds = EpisodeDataset(ensure_default_dataset(lambda *_: None))
    rows = [
        "| split | scenes | episodes | categories | easy % | medium % | hard % | start fallback |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for split in ds.split_names():
        st = ds.stats(split)
        d = st["difficulty"]
        rows.append(
            f"| `{split}` | {st['scenes']} | {st['episodes']:,} | {len(st['categories'])} | {d['easy']} | "
            f"{d['medium']} | {d['hard']} | {st['start_fallback']} |"
        )
    return "\n".join(rows)


def _metrics(kind: str | None) -> str:
    from biovln_ms.eval.aggregate import kind_metrics

    if kind not in ("single", "protocol"):
        raise PluginError(f"docs: no metrics table {kind!r}; known: single, protocol")
    at = {"end": "at the end", "trace": "every step", "count": "actions where true", "steps": "those actions"}
    over = {"all": "all (errored: 0)", "ran": "that ran", "successes": "successes"}
    rows = [
        "| record key | measure | recorded | aggregate | unit | over episodes | 95 % interval |",
        "|---|---|---|---|---|---|---|",
    ]
    for key, (metric, cls) in kind_metrics(kind == "protocol").items():
        aggs = metric.aggregates or (None,)
        for a in aggs:
            if a is None:
                cells = ["–", "–", "–", "–"]
            else:
                ci = {"wilson": "Wilson", "bootstrap": "bootstrap", None: "–"}[a.interval]
                cells = [f"`{a.key}` ({a.label}, {a.how})", a.unit, over[a.over], ci]
            rows.append(f"| `{key}` | `{cls.uuid}` | {at[metric.at]} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


KINDS = {
    "table": _table,
    "report": _report,
    "catalog": _catalog,
    "dataset": _dataset,
    "protocols": _protocols,
    "metrics": _metrics,
}
# Sphinx roles in docstrings (:class:`~a.b.C`), as mkdocstrings renders them: ":class:<code>~a.b.C</code>"
SPHINX_ROLE = re.compile(r":(?:class|meth|func|mod|data|attr|obj|exc):<code>(~?)([^<]*)</code>")


def on_page_markdown(markdown: str, page, **_) -> str:
    def expand(m: re.Match) -> str:
        kind, name = m.group(1), m.group(2)
        if kind not in KINDS:
            raise PluginError(f"docs/{page.file.src_path}: unknown placeholder {m.group(0)!r}")
        return KINDS[kind](name)

    return PLACEHOLDER.sub(expand, markdown)


def on_page_content(html: str, page, **_) -> str:
    """Sphinx roles in the API pages' docstrings become plain code (``~`` keeps the last name, as Sphinx)."""
    return SPHINX_ROLE.sub(lambda m: f"<code>{m[2].rsplit('.', 1)[-1] if m[1] else m[2]}</code>", html)
