"""A defensive glTF 2.0 / GLB reader for designer-authored scenes (untrusted input).

It reads the node tree with world transforms and the POSITION data of each mesh, and refuses, with a
message naming the file and the problem: a bad magic/version/length, a malformed JSON chunk, chunk
or accessor ranges outside the buffer, absurd sizes (file, nodes, vertices, tree depth), node cycles,
missing referenced nodes/meshes/accessors, non-finite transforms, and buffer/image URIs that point
outside the file (external URIs are refused by default; with ``allow_external`` only files inside the
GLB's own folder are read). It never writes anything.

glTF is Y-up (+Y up, +Z front); BioVLN is Z-up: world points are returned converted,
``(x, y, z)_ours = (x, -z, y)_glTF`` (the inverse of Blender's "+Y up" export).
"""

from __future__ import annotations

import base64
import json
import math
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.frames import Y_UP_TO_Z_UP
from biovln_ms.scene.spec import json_depth

MAGIC = 0x46546C67  # b"glTF"
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942
MAX_COORDINATE = 1e4  # m: anything farther is a units or transform error, not a lab


@dataclass(frozen=True)
class Limits:
    max_file_bytes: int = 256 * 2**20
    max_nodes: int = 20_000
    max_depth: int = 64
    max_vertices: int = 5_000_000


class GLTFError(BioVLNError):
    """An unreadable, malformed or unsafe glTF/GLB file."""


@dataclass
class Node:
    index: int
    name: str
    world: np.ndarray  # 4x4, Z-up world frame
    mesh: int | None
    parent: int | None
    children: list[int] = field(default_factory=list)
    extras: dict = field(default_factory=dict)

    @property
    def origin(self) -> np.ndarray:
        return self.world[:3, 3].copy()


@dataclass
class GLTFScene:
    path: Path
    nodes: list[Node]
    _doc: dict
    _buffers: list[bytes]
    _limits: Limits
    _points: dict[int, np.ndarray] = field(default_factory=dict)  # mesh_points per node, read once

    def subtree(self, node: Node) -> list[Node]:
        out, stack = [], [node.index]
        while stack:
            n = self.nodes[stack.pop()]
            out.append(n)
            stack.extend(n.children)
        return out

    def mesh_points(self, node: Node) -> np.ndarray:
        """World (Z-up) vertices of the node's own mesh, (N, 3); empty for an empty node. Each mesh's
        accessors are decoded once per scene."""
        if node.index not in self._points:
            self._points[node.index] = self._read_mesh_points(node)
        return self._points[node.index]

    def _read_mesh_points(self, node: Node) -> np.ndarray:
        if node.mesh is None:
            return np.zeros((0, 3))
        mesh = _item(self._doc, "meshes", node.mesh, self.path, f"node '{node.name}'")
        pts = []
        for k, prim in enumerate(_list(mesh, "primitives", self.path, f"meshes[{node.mesh}]")):
            attrs = prim.get("attributes") if isinstance(prim, dict) else None
            if not isinstance(attrs, dict):
                raise GLTFError(
                    f"meshes[{node.mesh}].primitives[{k}] has no attributes object",
                    source=str(self.path),
                    field=f"meshes[{node.mesh}]",
                    fix="re-export the file",
                )
            if "POSITION" in attrs:
                pts.append(self._positions(attrs["POSITION"], node.name))
        if not pts:
            return np.zeros((0, 3))
        world = np.concatenate(pts) @ node.world[:3, :3].T + node.world[:3, 3]
        if not np.isfinite(world).all() or np.abs(world).max() > MAX_COORDINATE:
            raise GLTFError(
                f"node '{node.name}' puts vertices at absurd or non-finite coordinates",
                source=str(self.path),
                field=node.name,
                fix="check the node's scale and the units (metres) of the export",
            )
        return world

    def subtree_points(self, node: Node) -> np.ndarray:
        parts = [self.mesh_points(n) for n in self.subtree(node)]
        return np.concatenate(parts) if parts else np.zeros((0, 3))

    def _positions(self, accessor_index: int, where: str) -> np.ndarray:
        doc = self._doc
        acc = _item(doc, "accessors", accessor_index, self.path, f"node '{where}'")
        if acc.get("componentType") != 5126 or acc.get("type") != "VEC3":
            raise GLTFError(
                f"POSITION accessor {accessor_index} is not float32 VEC3",
                source=str(self.path),
                field=f"accessors[{accessor_index}]",
                fix="export positions as float32 (Blender's default)",
            )
        count = acc.get("count")
        if not _index(count) or count < 0 or count > self._limits.max_vertices:
            raise GLTFError(
                f"accessor {accessor_index} has an absurd count {count!r}",
                source=str(self.path),
                field=f"accessors[{accessor_index}].count",
                fix=f"at most {self._limits.max_vertices} vertices",
            )
        if "bufferView" not in acc:
            return np.zeros((count, 3))
        view = _item(doc, "bufferViews", acc["bufferView"], self.path, f"accessors[{accessor_index}]")
        buf_index = view.get("buffer", -1)
        if not (_index(buf_index) and 0 <= buf_index < len(self._buffers)):
            raise GLTFError(
                f"bufferView {acc['bufferView']} names a missing buffer",
                source=str(self.path),
                field=f"bufferViews[{acc['bufferView']}].buffer",
                fix="re-export the file",
            )
        data = self._buffers[buf_index]
        numbers = [
            view.get("byteStride") or 12,
            view.get("byteOffset", 0),
            acc.get("byteOffset", 0),
            view.get("byteLength", 0),
        ]
        if not all(_index(v) and v >= 0 for v in numbers):
            raise GLTFError(
                f"accessor {accessor_index} or its bufferView has a malformed offset, length or stride",
                source=str(self.path),
                field=f"accessors[{accessor_index}]",
                fix="re-export the file",
            )
        stride = numbers[0]
        start = int(view.get("byteOffset", 0)) + int(acc.get("byteOffset", 0))
        end = start + (count - 1) * stride + 12 if count else start
        view_end = int(view.get("byteOffset", 0)) + int(view.get("byteLength", 0))
        if stride < 12 or start < 0 or end > view_end or view_end > len(data):
            raise GLTFError(
                f"accessor {accessor_index} reads outside its buffer",
                source=str(self.path),
                field=f"accessors[{accessor_index}]",
                fix="the file is truncated or corrupt; re-export it",
            )
        if count == 0:
            return np.zeros((0, 3))
        raw = np.frombuffer(data, np.uint8, end - start, start)
        rows = np.lib.stride_tricks.as_strided(raw, (count, 12), (stride, 1))
        pts = np.ascontiguousarray(rows).view("<f4").reshape(count, 3).astype(float)
        if not np.isfinite(pts).all():
            raise GLTFError(
                f"accessor {accessor_index} holds non-finite positions",
                source=str(self.path),
                field=f"accessors[{accessor_index}]",
                fix="fix the mesh in the authoring tool",
            )
        return pts


def _list(obj: dict, key: str, path: Path, where: str) -> list:
    """``obj[key]`` as a list ([] when absent); anything else is refused."""
    v = obj.get(key)
    if v is None:
        return []
    if not isinstance(v, list):
        raise GLTFError(
            f"{where}.{key} is not a list", source=str(path), field=f"{where}.{key}", fix="re-export the file"
        )
    return v


def _index(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _item(doc: dict, key: str, index, path: Path, where: str) -> dict:
    items = doc.get(key)
    if (
        not isinstance(items, list)
        or not _index(index)
        or not 0 <= index < len(items)
        or not isinstance(items[index], dict)
    ):
        raise GLTFError(
            f"{where} refers to {key}[{index!r}], which does not exist",
            source=str(path),
            field=key,
            fix="the file is inconsistent; re-export it",
        )
    return items[index]


def _split_glb(raw: bytes, path: Path) -> tuple[dict, bytes | None]:
    if len(raw) < 20:
        raise GLTFError("too short to be a GLB", source=str(path), fix="export a binary glTF (.glb)")
    magic, version, length = struct.unpack_from("<III", raw, 0)
    if magic != MAGIC:
        raise GLTFError(
            "not a GLB (bad magic)", source=str(path), fix="export a binary glTF (.glb) or a .gltf"
        )
    if version != 2:
        raise GLTFError(
            f"glTF version {version} is not supported",
            source=str(path),
            field="version",
            fix="export glTF 2.0",
        )
    if length != len(raw):
        raise GLTFError(
            f"header says {length} bytes, the file has {len(raw)}",
            source=str(path),
            field="length",
            fix="the file is truncated or corrupt; re-export it",
        )
    pos, doc, binary = 12, None, None
    while pos + 8 <= len(raw):
        clen, ctype = struct.unpack_from("<II", raw, pos)
        if pos + 8 + clen > len(raw):
            raise GLTFError(
                "a chunk runs past the end of the file", source=str(path), fix="re-export the file"
            )
        body = raw[pos + 8 : pos + 8 + clen]
        if doc is None:
            if ctype != CHUNK_JSON:
                raise GLTFError("the first chunk is not JSON", source=str(path), fix="re-export the file")
            doc = _parse_json(body, path)
        elif ctype == CHUNK_BIN and binary is None:
            binary = body
        pos += 8 + clen
    if doc is None:
        raise GLTFError("no JSON chunk", source=str(path), fix="re-export the file")
    return doc, binary


def _parse_json(body: bytes, path: Path, max_depth: int = Limits.max_depth) -> dict:

    if json_depth(body) > max_depth:
        raise GLTFError(
            f"the JSON chunk nests deeper than {max_depth} levels", source=str(path), fix="re-export the file"
        )
    try:
        doc = json.loads(body.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise GLTFError(f"malformed JSON chunk ({e})", source=str(path), fix="re-export the file") from None
    if not isinstance(doc, dict):
        raise GLTFError("the JSON chunk is not an object", source=str(path), fix="re-export the file")
    return doc


def _resolve_uri(uri: str, path: Path, allow_external: bool, max_bytes: int) -> bytes:
    if uri.startswith("data:"):
        head, _, payload = uri.partition(",")
        if ";base64" not in head:
            raise GLTFError(
                "only base64 data URIs are supported", source=str(path), field="buffers.uri", fix="re-export"
            )
        if len(payload) * 3 // 4 > max_bytes:
            raise GLTFError(
                "an embedded buffer is absurdly large", source=str(path), field="buffers.uri", fix="re-export"
            )
        try:
            return base64.b64decode(payload, validate=True)
        except ValueError:
            raise GLTFError(
                "a data URI is not valid base64", source=str(path), field="buffers.uri", fix="re-export"
            ) from None
    if not allow_external:
        raise GLTFError(
            f"external URI '{uri[:80]}' refused",
            source=str(path),
            field="buffers.uri",
            fix="embed the data (export as .glb), or pass allow_external=True for files beside it",
        )
    if "://" in uri or uri.startswith(("/", "\\")):
        raise GLTFError(
            f"URI '{uri[:80]}' is not a relative path",
            source=str(path),
            field="buffers.uri",
            fix="only files inside the scene's own folder can be read",
        )
    folder = path.parent.resolve()
    target = (folder / uri).resolve()
    if folder not in target.parents or not target.is_file():
        raise GLTFError(
            f"URI '{uri[:80]}' points outside the scene's folder or to no file",
            source=str(path),
            field="buffers.uri",
            fix="keep referenced files beside the scene file",
        )
    if target.stat().st_size > max_bytes:
        raise GLTFError(
            f"'{uri[:80]}' is absurdly large", source=str(path), field="buffers.uri", fix="re-export"
        )
    return target.read_bytes()


def _local_matrix(node: dict, index: int, path: Path) -> np.ndarray:
    where = f"nodes[{index}] ('{node.get('name', '')}')"
    try:
        if "matrix" in node:
            m = np.asarray(node["matrix"], float)
            if m.shape != (16,):
                raise ValueError
            m = m.reshape(4, 4).T  # column-major
        else:
            t = np.asarray(node.get("translation", [0, 0, 0]), float)
            q = np.asarray(node.get("rotation", [0, 0, 0, 1]), float)
            s = np.asarray(node.get("scale", [1, 1, 1]), float)
            if t.shape != (3,) or q.shape != (4,) or s.shape != (3,):
                raise ValueError
            x, y, z, w = q
            n = math.sqrt(x * x + y * y + z * z + w * w) if np.isfinite(q).all() else float("nan")
            if not n > 1e-9:
                raise ValueError
            x, y, z, w = q / n
            r = np.array(
                [
                    [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                    [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                    [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
                ]
            )
            m = np.eye(4)
            m[:3, :3] = r * s
            m[:3, 3] = t
    except (TypeError, ValueError):
        raise GLTFError(
            f"{where} has a malformed transform",
            source=str(path),
            field=where,
            fix="matrix: 16 numbers; translation/scale: 3; rotation: a non-zero quaternion of 4",
        ) from None
    if not np.isfinite(m).all():
        raise GLTFError(
            f"{where} has a non-finite transform",
            source=str(path),
            field=where,
            fix="fix the node's transform",
        )
    return m


def read_gltf(path: str | Path, allow_external: bool = False, limits: Limits = Limits()) -> GLTFScene:
    """Parse a .glb (or .gltf) file into nodes with Z-up world transforms."""
    path = Path(path)
    if not path.is_file():
        raise GLTFError("no such file", source=str(path), fix="pass the path of a .glb exported from Blender")
    size = path.stat().st_size
    if size > limits.max_file_bytes:
        raise GLTFError(
            f"{size / 2**20:.0f} MB is more than the {limits.max_file_bytes / 2**20:.0f} MB limit",
            source=str(path),
            fix="decimate the meshes, or raise Limits.max_file_bytes",
        )
    raw = path.read_bytes()
    if raw[:4] == b"glTF" or path.suffix.lower() == ".glb":
        doc, binary = _split_glb(raw, path)
    else:
        doc, binary = _parse_json(raw, path), None
    asset = doc.get("asset")
    if not isinstance(asset, dict) or not str(asset.get("version", "")).startswith("2"):
        raise GLTFError(
            "asset.version is not 2.x", source=str(path), field="asset.version", fix="export glTF 2.0"
        )
    buffers = []
    for i, b in enumerate(_list(doc, "buffers", path, "glTF")):
        if not isinstance(b, dict):
            raise GLTFError(
                f"buffers[{i}] is not an object", source=str(path), field=f"buffers[{i}]", fix="re-export"
            )
        if "uri" in b:
            buffers.append(_resolve_uri(str(b["uri"]), path, allow_external, limits.max_file_bytes))
        elif i == 0 and binary is not None:
            buffers.append(binary)
        else:
            raise GLTFError(
                f"buffers[{i}] has no data", source=str(path), field=f"buffers[{i}]", fix="re-export"
            )
    for i, im in enumerate(_list(doc, "images", path, "glTF")):
        if isinstance(im, dict) and "uri" in im and not str(im["uri"]).startswith("data:"):
            _resolve_uri(
                str(im["uri"]), path, allow_external, limits.max_file_bytes
            )  # refuses unsafe references
    raw_nodes = _list(doc, "nodes", path, "glTF")
    if len(raw_nodes) > limits.max_nodes:
        raise GLTFError(
            f"{len(raw_nodes)} nodes is more than the {limits.max_nodes} limit",
            source=str(path),
            field="nodes",
            fix="join meshes in the authoring tool",
        )
    n_meshes = len(_list(doc, "meshes", path, "glTF"))
    parent: dict[int, int] = {}
    for i, nd in enumerate(raw_nodes):
        if not isinstance(nd, dict):
            raise GLTFError(
                f"nodes[{i}] is not an object", source=str(path), field=f"nodes[{i}]", fix="re-export"
            )
        if "mesh" in nd and not (_index(nd["mesh"]) and 0 <= nd["mesh"] < n_meshes):
            raise GLTFError(
                f"nodes[{i}] refers to a missing mesh {nd['mesh']!r}",
                source=str(path),
                field=f"nodes[{i}].mesh",
                fix="re-export",
            )
        for c in _list(nd, "children", path, f"nodes[{i}]"):
            if not (_index(c) and 0 <= c < len(raw_nodes)):
                raise GLTFError(
                    f"nodes[{i}] has a missing child {c!r}",
                    source=str(path),
                    field=f"nodes[{i}].children",
                    fix="re-export",
                )
            if c in parent or c == i:
                raise GLTFError(
                    f"node {c} has two parents or is its own child (a cycle)",
                    source=str(path),
                    field=f"nodes[{i}].children",
                    fix="re-export",
                )
            parent[c] = i
    for start in parent:  # every parent chain must end at a root
        i, steps = start, 0
        while i in parent:
            i, steps = parent[i], steps + 1
            if steps > len(raw_nodes):
                raise GLTFError(
                    f"node {start}'s ancestors form a cycle", source=str(path), field="nodes", fix="re-export"
                )
    scenes = _list(doc, "scenes", path, "glTF") or [
        {"nodes": [i for i in range(len(raw_nodes)) if i not in parent]}
    ]
    scene_index = doc.get("scene", 0)
    scene = _item({"scenes": scenes}, "scenes", scene_index, path, "scene")
    roots = scene.get("nodes", [])
    if not isinstance(roots, list) or any(
        not (_index(r) and 0 <= r < len(raw_nodes)) or r in parent for r in roots
    ):
        raise GLTFError(
            "the scene's root nodes are missing or are not roots",
            source=str(path),
            field="scenes.nodes",
            fix="re-export",
        )
    nodes: dict[int, Node] = {}
    stack = [(r, Y_UP_TO_Z_UP, None, 0) for r in reversed(roots)]
    while stack:
        i, parent_world, par, depth = stack.pop()
        if depth > limits.max_depth:
            raise GLTFError(
                f"the node tree is deeper than {limits.max_depth}",
                source=str(path),
                field="nodes",
                fix="flatten it",
            )
        if i in nodes:
            raise GLTFError(
                f"node {i} is reached twice (a cycle)", source=str(path), field="nodes", fix="re-export"
            )
        nd = raw_nodes[i]
        world = parent_world @ _local_matrix(nd, i, path)
        extras = nd.get("extras") if isinstance(nd.get("extras"), dict) else {}
        nodes[i] = Node(
            i,
            str(nd.get("name", f"node_{i}"))[:200],
            world,
            nd.get("mesh"),
            par,
            list(nd.get("children", []) or []),
            extras,
        )
        stack.extend((c, world, i, depth + 1) for c in reversed(nd.get("children", []) or []))
    ordered = [nodes[i] for i in sorted(nodes)]
    remap = {n.index: k for k, n in enumerate(ordered)}
    for n in ordered:  # nodes outside the scene are dropped; indices refer to the list
        n.children = [remap[c] for c in n.children if c in remap]
        n.parent = remap.get(n.parent) if n.parent is not None else None
        n.index = remap[n.index]
    return GLTFScene(path, ordered, doc, buffers, limits)
