"""The README demo: what the platform can show so far, written as PNG and Markdown."""

from __future__ import annotations

from pathlib import Path

from biovln_ms.catalog import load_catalog
from biovln_ms.render.asset_preview import contact_sheet


def run_demo(out_dir: Path, echo=print) -> dict[str, Path]:
    """Render the asset contact sheet and write the catalog with measured surface colours."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    cat = load_catalog()
    sheet = out_dir / "asset_sheet.png"
    renders = {r.name: r for r in contact_sheet(sheet, cat)}
    lines = ["# BioVLN-MS catalog (paper Table 2 + Tables 6, 8)", "",
             "| asset | dimensions (m) | placement | face | d_half | delta | r | colours front / back |",
             "|---|---|---|---|---|---|---|---|"]
    for a in cat.assets():
        r = renders[a.name]
        dims = " x ".join(f"{d:.2f}" for d in a.dimensions)
        lines.append(f"| {a.name} | {dims} | {a.placement} | {a.face or '-'} | {a.d_half} | {a.approach_distance} | "
                     f"{a.success_radius} | {r.front_colors} / {r.back_colors} |")
    table = out_dir / "catalog.md"
    table.write_text("\n".join(lines) + "\n")
    echo(f"wrote {sheet} and {table}")
    return {"sheet": sheet, "table": table}
