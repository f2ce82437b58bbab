"""Regenerate the pictures of the README and the docs from the code (nothing here is drawn by hand).

    python docs/images/generate.py [--only map view]

- ``lab_s150_v0_view.png``: the held-out scene ``lab_s150_v0`` rendered by SAPIEN from above at an
  angle under the ``quality`` lighting (``biovln_ms.render.scene_view.render_overview``; needs a Vulkan
  driver, lavapipe is fine);
- ``lab_s150_v0_episode.png``: its top-down map with Zones 1/2/3, faces, goals, the navigable islands
  and one episode's start, goal, view points and exact shortest path (``biovln_ms.scene.topdown``);
- ``molbio_s3_v0_dressed.png``: the top-down map of ``molecular_biology`` seed 3 with its lab dressing;
- ``templates/<scene>_robot.png`` and ``templates/<scene>_top.png``: seed 0 of every template (the
  molecular-biology lab with its dressing) under ``quality``, from the robot's head camera at its first
  episode's start, facing its target or the way its path sets off, and straight down from above
  (``biovln_ms.render.scene_view.render_robot_and_top_views``);
- ``busy_episode.png``: one episode of the ``busy_val`` split (people in the lab) recorded with the oracle
  by ``biovln-ms record``: the head camera beside the map, with the people and their ways, at the step where
  a person comes nearest the robot (``biovln_ms.episode_video``);
- ``asset_sheet.png``: the contact sheet of every asset under ``quality`` (``biovln-ms assets preview``).

The view, the map and the sheet are what ``biovln-ms demo`` writes, at a size fit for a web page.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from PIL import Image, ImageChops

from biovln_ms.splits import FOUR_CATEGORIES
from biovln_ms.episodes.generator import EpisodeSampler
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import scene_navigation
from biovln_ms.scene.topdown import save_map

HERE = Path(__file__).resolve().parent
WIDTH = 900  # px: the pictures are shown at page width


def _shrink(path: Path) -> Path:
    """Crop the empty margin (the colour of the top-left pixel), fit the page width, 256 colours."""
    img = Image.open(path).convert("RGB")
    margin = ImageChops.difference(img, Image.new("RGB", img.size, img.getpixel((0, 0))))
    x0, y0, x1, y1 = margin.convert("L").point(lambda v: 255 if v > 8 else 0).getbbox()
    img = img.crop((max(x0 - 8, 0), max(y0 - 8, 0), min(x1 + 8, img.width), min(y1 + 8, img.height)))
    if img.width > WIDTH:
        img = img.resize((WIDTH, round(img.height * WIDTH / img.width)), Image.LANCZOS)
    img.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parts = ("view", "map", "dressed", "templates", "sheet", "busy")
    ap.add_argument("--only", nargs="*", choices=parts, default=parts)
    ap.add_argument("--out", type=Path, default=HERE)
    args = ap.parse_args()
    spec = generate_scene("single_room", 150, required_categories=FOUR_CATEGORIES)
    if "map" in args.only:
        nav = scene_navigation(spec)
        episode = EpisodeSampler(spec, nav).episodes(1, seed=0)[0]
        print(
            _shrink(save_map(spec, args.out / f"{spec.name}_episode.png", episode=episode, nav=nav, dpi=100))
        )
    if "view" in args.only:
        from biovln_ms.render.scene_view import render_overview

        view = render_overview(spec, args.out / f"{spec.name}_view.png", size=(1200, 800), lighting="quality")
        print(_shrink(view))
    if "dressed" in args.only:
        dressed = generate_scene("molecular_biology", 3, dressing=True)
        print(_shrink(save_map(dressed, args.out / f"{dressed.name}.png", dpi=100)))
    if "templates" in args.only:
        from biovln_ms.render.scene_view import render_robot_and_top_views
        from biovln_ms.scene.templates import template_names

        for name in template_names():
            scene = generate_scene(name, 0, dressing=name == "molecular_biology")
            for png in render_robot_and_top_views(scene, args.out / "templates", "quality"):
                print(_shrink(png))
    if "sheet" in args.only:
        from biovln_ms.render.asset_preview import contact_sheet

        sheet = args.out / "asset_sheet.png"
        contact_sheet(sheet, lighting="quality")
        print(_shrink(sheet))
    if "busy" in args.only:
        print(_shrink(_busy_still(args.out / "busy_episode.png")))


#: the busy episode of the docs figure: its position in busy_val
BUSY_EPISODE = 28


def _busy_still(out: Path) -> Path:
    """A still of the oracle's busy episode: the frame where a person is nearest the robot."""
    import tempfile

    import imageio.v2 as imageio

    from biovln_ms.episode_video import record_episode
    from biovln_ms.variants import BUSY_ENV

    with tempfile.TemporaryDirectory() as tmp:
        video = Path(tmp) / "busy.mp4"
        gaps = record_episode(video, "busy_val", BUSY_EPISODE, "oracle", env_id=BUSY_ENV, gaps=True)["gaps"]
        with imageio.get_reader(video) as r:
            frame = r.get_data(min(range(len(gaps)), key=gaps.__getitem__))
    Image.fromarray(frame).save(out)
    return out


if __name__ == "__main__":
    main()
