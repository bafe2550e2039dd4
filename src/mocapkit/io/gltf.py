"""Motion <-> glTF 2.0 (``.glb`` binary, ``.gltf`` JSON with the buffer embedded).

What is written (:func:`write_gltf`):

* one node per joint, nested as the hierarchy, with the rest offset as its translation and no
  rotation (the rest pose is the BVH rest pose), then one node per End Site;
* a skin over all of them, whose inverse bind matrices undo the rest pose;
* one animation at the file's frame times: a rotation sampler per joint, a translation sampler
  for the root and for every joint whose position the file animates (Bandai's do);
* a simple mesh, a box along each bone skinned rigidly to it, so the file shows the character
  when opened in any viewer;
* glTF's frame: metres and +Y up. Lengths are multiplied by the body's metres per unit and the
  body's up axis is turned onto +Y (:func:`gltf_space`), both from :func:`mocapkit.body.body_of`.

The file carries mocapkit's own metadata under ``extras.mocapkit`` (exact frame time, channel
layout, End Site names, the source's up axis and unit), which :func:`read_gltf` uses to give
back the same skeleton. :func:`read_gltf` also reads other exporters' skinned animations: the
rest translation of each joint node is its offset and its (animated or rest) rotation its local
rotation, resampled at a constant rate.
"""

from __future__ import annotations

import base64
import math
import struct
from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import POSITION_CHANNELS, Skeleton
from mocapkit.io.atomic import atomic_write_bytes
from mocapkit.io.errors import MocapFileError

__all__ = [
    "FORMAT",
    "GLTFError",
    "gltf_space",
    "read_gltf",
    "to_gltf_json",
    "up_rotation",
    "write_gltf",
]

FORMAT = "mocapkit-gltf-1"
"""``extras.mocapkit.format`` of files this module writes."""

_FLOAT, _USHORT, _UINT = 5126, 5123, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_DATA_URI = "data:application/octet-stream;base64,"
_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
_DTYPES = {5120: "<i1", 5121: "<u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}

# Proper rotations taking each signed up axis onto +Y. For Z-up the source -Y (Blender's
# "forward") lands on +Z, glTF's forward, as Blender's own glTF exporter does.
_UP_TO_Y: dict[str, tuple[tuple[int, int, int], ...]] = {
    "Y": ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
    "-Y": ((1, 0, 0), (0, -1, 0), (0, 0, -1)),
    "Z": ((1, 0, 0), (0, 0, 1), (0, -1, 0)),
    "-Z": ((1, 0, 0), (0, 0, -1), (0, 1, 0)),
    "X": ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
    "-X": ((0, 1, 0), (-1, 0, 0), (0, 0, 1)),
}


class GLTFError(MocapFileError):
    """A glTF file mocapkit cannot read as a motion."""


def up_rotation(up: str) -> np.ndarray:
    """The (3, 3) proper rotation taking the signed axis ``up`` ("Y", "Z", "-Y", ...) onto +Y."""
    key = up.strip().upper().lstrip("+")
    if key not in _UP_TO_Y:
        raise ValueError(f"up axis must be X, Y or Z with an optional sign, got {up!r}")
    return np.array(_UP_TO_Y[key], dtype=np.float64)


def _transform_motion(motion: Motion, R: np.ndarray, scale: float) -> Motion:
    """``motion`` with every length multiplied by ``scale`` and the world turned by ``R``:
    positions become ``scale * R p`` and local rotations ``R L R^T``, so FK positions of the
    result are ``scale * R`` times those of ``motion`` (parents' frames turn with the world)."""
    sk = motion.skeleton
    qr = rot.matrix_to_quat(R)

    def vec(v: np.ndarray) -> np.ndarray:
        return scale * (v @ R.T)

    rotations = rot.quat_mul(rot.quat_mul(qr, motion.rotations), rot.quat_conj(qr))
    skeleton = Skeleton(
        sk.names,
        sk.parents,
        vec(sk.offsets),
        sk.channels,
        sk.end_site_parents,
        vec(sk.end_site_offsets),
        sk.end_site_names,
        1.0,
    )
    return Motion(
        skeleton,
        rot.quat_normalize(rotations),
        vec(motion.root_positions),
        motion.frame_time,
        None if motion.translations is None else vec(motion.translations),
    )


def gltf_space(
    motion: Motion, up: str | None = None, metres_per_unit: float | None = None
) -> tuple[Motion, np.ndarray, float]:
    """``motion`` in glTF's frame (metres, +Y up), with the rotation ``R`` and the factor
    ``s`` used: FK positions of the result are ``s * R @ p`` for positions ``p`` of ``motion``.

    ``up`` and ``metres_per_unit`` default to the body model's (:func:`mocapkit.body.body_of`:
    the up axis measured on the poses, the unit the file states or the guess).
    """
    if up is None or metres_per_unit is None:
        from mocapkit.body import body_of

        body = body_of(motion)
        up = body.up if up is None else up
        metres_per_unit = body.metres_per_unit if metres_per_unit is None else metres_per_unit
    if not (math.isfinite(metres_per_unit) and metres_per_unit > 0):
        raise ValueError(f"metres per unit must be positive, got {metres_per_unit!r}")
    R = up_rotation(up)
    return _transform_motion(motion, R, float(metres_per_unit)), R, float(metres_per_unit)


# ------------------------------------------------------------------------------------ writing
class _Blob:
    """The binary buffer being built, with its buffer views and accessors (plain dicts)."""

    def __init__(self) -> None:
        self.chunks: list[bytes] = []
        self.size = 0
        self.views: list[dict[str, Any]] = []
        self.accessors: list[dict[str, Any]] = []

    def add(
        self, arr: np.ndarray, kind: str, *, target: int | None = None, bounds: bool = False
    ) -> int:
        """Append ``arr`` (float32, uint16 or uint32) as one view and one accessor; its index."""
        arr = np.ascontiguousarray(arr)
        ctype = {np.float32: _FLOAT, np.uint16: _USHORT, np.uint32: _UINT}[arr.dtype.type]
        pad = -self.size % 4  # accessors must start on their component size (<= 4)
        if pad:
            self.chunks.append(b"\0" * pad)
            self.size += pad
        data = arr.tobytes()
        view: dict[str, Any] = {"buffer": 0, "byteOffset": self.size, "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        self.views.append(view)
        self.chunks.append(data)
        self.size += len(data)
        count = arr.shape[0]
        acc: dict[str, Any] = {
            "bufferView": len(self.views) - 1,
            "componentType": ctype,
            "count": int(count),
            "type": kind,
        }
        if bounds and count:
            flat = arr.reshape(count, -1)
            acc["min"] = [float(v) for v in flat.min(axis=0)]
            acc["max"] = [float(v) for v in flat.max(axis=0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def data(self) -> bytes:
        out = b"".join(self.chunks)
        return out + b"\0" * (-len(out) % 4)


def _box(a: np.ndarray, b: np.ndarray, half: float) -> tuple[np.ndarray, np.ndarray]:
    """A box around the segment a-b (or a cube at ``a`` when they coincide): 24 vertices (4 per
    face, so that each face has its own normal) and their normals."""
    d = b - a
    length = float(np.linalg.norm(d))
    if length < 1e-9:
        ax = np.eye(3)
        centre, ext = a, np.array([half, half, half])
    else:
        x = d / length
        helper = np.array([0.0, 1.0, 0.0]) if abs(x[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
        y = np.cross(x, helper)
        y /= np.linalg.norm(y)
        z = np.cross(x, y)
        ax = np.stack([x, y, z])
        centre, ext = (a + b) / 2, np.array([length / 2, half, half])
    verts, normals = [], []
    for axis in range(3):
        u, v = [k for k in range(3) if k != axis]
        for sign in (1.0, -1.0):
            n = sign * ax[axis]
            # corners in counter-clockwise order seen from outside (u x v = +/- axis)
            cs = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
            if (sign > 0) != (np.dot(np.cross(ax[u], ax[v]), ax[axis]) > 0):
                cs = cs[::-1]
            for cu, cv in cs:
                p = centre + n * ext[axis] + cu * ext[u] * ax[u] + cv * ext[v] * ax[v]
                verts.append(p)
                normals.append(n)
    return np.array(verts), np.array(normals)


def _mesh(rest: np.ndarray, parents: np.ndarray, height: float) -> dict[str, np.ndarray]:
    """Boxes from every joint to each of its children (joints and End Sites; a cube at a joint
    with none), each skinned wholly to the joint it hangs from. ``rest``: (N, 3) rest positions
    of the skin's joints; ``parents``: (N,) their parents."""
    children: list[list[int]] = [[] for _ in range(len(rest))]
    for k, p in enumerate(parents):
        if p >= 0:
            children[p].append(k)
    pos, nrm, jnt = [], [], []
    for j in range(len(rest)):
        ends = children[j] or [j]  # a leaf: a small cube marks it
        for c in ends:
            length = float(np.linalg.norm(rest[c] - rest[j]))
            # thick enough to see, thin enough not to swallow short bones (fingers)
            half = float(np.clip(0.12 * length, 0.004 * height, 0.025 * height))
            if c == j:
                half = 0.01 * height
            v, n = _box(rest[j], rest[c], half)
            pos.append(v)
            nrm.append(n)
            jnt.append(np.full(len(v), j))
    positions = np.concatenate(pos)
    quad = np.array([0, 1, 2, 0, 2, 3])
    indices = (np.arange(0, len(positions), 4)[:, None] + quad).reshape(-1)
    return {
        "POSITION": positions.astype(np.float32),
        "NORMAL": np.concatenate(nrm).astype(np.float32),
        "JOINTS_0": np.stack(
            [np.concatenate(jnt)] + [np.zeros(len(positions), int)] * 3, axis=1
        ).astype(np.uint16),
        "WEIGHTS_0": np.repeat([[1.0, 0.0, 0.0, 0.0]], len(positions), 0).astype(np.float32),
        "indices": indices.astype(np.uint32),
    }


def _end_site_names(sk: Skeleton) -> list[str]:
    """Node names of the End Sites: the file's token where it has one, else ``<joint>_end``,
    made unique against the joints and each other (viewers key bones by name)."""
    taken = set(sk.names)
    out = []
    for e, p in enumerate(sk.end_site_parents):
        base = sk.end_site_names[e] or f"{sk.names[p]}_end"
        name, k = base, 1
        while name in taken:
            k += 1
            name = f"{base}.{k}"
        taken.add(name)
        out.append(name)
    return out


def to_gltf_json(
    motion: Motion, up: str | None = None, metres_per_unit: float | None = None
) -> tuple[dict[str, Any], bytes]:
    """The glTF document (a JSON-able dict whose one buffer has no ``uri`` yet) and its binary
    buffer for ``motion`` (see the module notes)."""
    motion.check_finite("cannot write glTF")
    if up is None or metres_per_unit is None:
        from mocapkit.body import body_of

        body = body_of(motion)
        up = body.up if up is None else up
        metres_per_unit = body.metres_per_unit if metres_per_unit is None else metres_per_unit
    src_up, src_mpu = up, metres_per_unit
    m, _, _ = gltf_space(motion, src_up, src_mpu)
    sk = m.skeleton
    J, E, F = sk.num_joints, len(sk.end_site_parents), m.num_frames

    # the skin's joints: the joints, then the End Sites (children of their joints)
    parents = np.concatenate([sk.parents, sk.end_site_parents]).astype(np.int64)
    local = np.concatenate([sk.offsets, sk.end_site_offsets])
    rest = np.zeros((J + E, 3))
    for k in range(J + E):
        rest[k] = local[k] + (rest[parents[k]] if parents[k] >= 0 else 0.0)
    names = list(sk.names) + _end_site_names(sk)

    blob = _Blob()
    nodes: list[dict[str, Any]] = []
    for k in range(J + E):
        node: dict[str, Any] = {"name": names[k]}
        t = [float(v) for v in local[k].astype(np.float32)]
        if any(t):
            node["translation"] = t
        kids = [c for c in range(J + E) if parents[c] == k]
        if kids:
            node["children"] = kids
        nodes.append(node)

    ibm = np.tile(np.eye(4, dtype=np.float32), (J + E, 1, 1))
    ibm[:, :3, 3] = -rest  # rest rotations are identity: undoing the rest pose is a translation
    ibm_acc = blob.add(ibm.transpose(0, 2, 1).reshape(J + E, 16), "MAT4")  # column-major

    # the boxes' thickness follows the rig's size (its rest pose's largest extent)
    height = max(float(np.ptp(rest, axis=0).max()), 1e-3)
    mesh = _mesh(rest, parents, height)
    attrs = {
        key: blob.add(
            arr,
            "VEC3" if arr.shape[1] == 3 else "VEC4",
            target=_ARRAY_BUFFER,
            bounds=key == "POSITION",
        )
        for key, arr in mesh.items()
        if key != "indices"
    }
    idx_acc = blob.add(mesh["indices"], "SCALAR", target=_ELEMENT_ARRAY_BUFFER)
    mesh_node = J + E
    nodes.append({"name": f"{sk.names[0]}_mesh", "mesh": 0, "skin": 0})

    doc: dict[str, Any] = {
        "asset": {"version": "2.0", "generator": "mocapkit"},
        "scene": 0,
        "scenes": [{"nodes": [0, mesh_node]}],
        "nodes": nodes,
        "skins": [{"joints": list(range(J + E)), "skeleton": 0, "inverseBindMatrices": ibm_acc}],
        "meshes": [
            {
                "name": "bones",
                "primitives": [{"attributes": attrs, "indices": idx_acc, "material": 0}],
            }
        ],
        "materials": [
            {
                "name": "bone",
                "pbrMetallicRoughness": {
                    "baseColorFactor": [0.8, 0.55, 0.3, 1.0],
                    "metallicFactor": 0.0,
                    "roughnessFactor": 0.7,
                },
            }
        ],
        "extras": {
            "mocapkit": {
                "format": FORMAT,
                "frame_time": motion.frame_time,
                "frames": F,
                "channels": [list(c) for c in sk.channels],
                "end_site_names": list(sk.end_site_names),
                "source_up": src_up,
                "source_metres_per_unit": float(src_mpu),
            }
        },
    }
    if F:
        times = blob.add((np.arange(F) * m.frame_time).astype(np.float32), "SCALAR", bounds=True)
        # continuous signs: viewers slerp between keys along the shorter arc anyway, but
        # curve editors (Blender) interpolate components
        q = rot.quat_unroll(m.rotations, axis=0)
        samplers: list[dict[str, Any]] = []
        channels: list[dict[str, Any]] = []

        def channel(node: int, path: str, values: np.ndarray) -> None:
            out = blob.add(values.astype(np.float32), "VEC4" if path == "rotation" else "VEC3")
            samplers.append({"input": times, "output": out, "interpolation": "LINEAR"})
            channels.append({"sampler": len(samplers) - 1, "target": {"node": node, "path": path}})

        moving = sk.has_position
        trans = m.local_translations()
        for j in range(J):
            channel(j, "rotation", q[:, j][:, [1, 2, 3, 0]])  # glTF: x, y, z, w
            if j == 0 or (moving[j] and m.translations is not None):
                channel(j, "translation", trans[:, j])
        doc["animations"] = [{"name": "take", "samplers": samplers, "channels": channels}]

    doc["accessors"] = blob.accessors
    doc["bufferViews"] = blob.views
    data = blob.data()
    doc["buffers"] = [{"byteLength": len(data)}]
    return doc, data


def write_gltf(
    motion: Motion, path: str | Path, up: str | None = None, metres_per_unit: float | None = None
) -> Path:
    """Write ``motion`` as glTF 2.0 atomically: binary ``.glb``, or ``.gltf`` (JSON with the
    buffer embedded as a data URI, one self-contained file). ``up`` and ``metres_per_unit``
    override the body model's up axis and unit (see :func:`gltf_space`)."""
    import pygltflib

    path = Path(path)
    doc, data = to_gltf_json(motion, up, metres_per_unit)
    if path.suffix.lower() == ".gltf":
        doc["buffers"][0]["uri"] = _DATA_URI + base64.b64encode(data).decode("ascii")
        gltf = pygltflib.GLTF2.from_dict(doc)
        return atomic_write_bytes(path, gltf.gltf_to_json().encode("utf-8"))
    gltf = pygltflib.GLTF2.from_dict(doc)
    gltf.set_binary_blob(data)
    return atomic_write_bytes(path, b"".join(gltf.save_to_bytes()))


# ------------------------------------------------------------------------------------ reading
def _buffers(gltf: Any, path: Path) -> list[bytes]:
    out = []
    for i, buf in enumerate(gltf.buffers or []):
        uri = buf.uri
        if uri is None:
            blob = gltf.binary_blob()
            if blob is None:
                raise GLTFError(path, None, f"buffer {i} has no data (no uri, no GLB chunk)")
            out.append(blob)
        elif uri.startswith("data:"):
            try:
                out.append(base64.b64decode(uri.split(",", 1)[1], validate=False))
            except (IndexError, ValueError) as e:
                raise GLTFError(path, None, f"buffer {i}: bad data URI ({e})") from None
        else:
            from urllib.parse import unquote

            try:
                out.append((path.parent / unquote(uri)).read_bytes())
            except OSError as e:
                raise GLTFError(path, None, f"buffer {i}: cannot read {uri!r}: {e}") from None
    return out


def _accessor(gltf: Any, bufs: list[bytes], index: int, path: Path) -> np.ndarray:
    """The values of accessor ``index`` as float64, shape (count, components)."""
    try:
        acc = gltf.accessors[index]
        if acc.sparse is not None:
            raise GLTFError(path, None, f"accessor {index}: sparse accessors are not supported")
        n = _COMPONENTS[acc.type]
        dtype = np.dtype(_DTYPES[acc.componentType])
        if acc.bufferView is None:
            return np.zeros((acc.count, n))
        view = gltf.bufferViews[acc.bufferView]
        data = bufs[view.buffer]
        start = (view.byteOffset or 0) + (acc.byteOffset or 0)
        stride = view.byteStride or n * dtype.itemsize
        if acc.count and start + stride * (acc.count - 1) + n * dtype.itemsize > len(data):
            raise GLTFError(path, None, f"accessor {index} runs past the end of its buffer")
        raw = np.lib.stride_tricks.as_strided(
            np.frombuffer(data, dtype=np.uint8, offset=start, count=len(data) - start)
            if acc.count
            else np.zeros(0, np.uint8),
            shape=(acc.count, n * dtype.itemsize),
            strides=(stride, 1),
        )
        out = np.ascontiguousarray(raw).view(dtype).reshape(acc.count, n).astype(np.float64)
        if acc.normalized and dtype.kind in "iu":
            out /= np.iinfo(dtype).max
        return out
    except GLTFError:
        raise
    except (IndexError, KeyError, TypeError, ValueError) as e:
        raise GLTFError(path, None, f"accessor {index} cannot be read: {e}") from None


def _node_matrix(node: Any) -> np.ndarray:
    if node.matrix is not None:
        return np.array(node.matrix, dtype=np.float64).reshape(4, 4).T  # column-major
    M = np.eye(4)
    if node.rotation is not None:
        x, y, z, w = node.rotation
        M[:3, :3] = rot.quat_to_matrix(rot.quat_normalize([w, x, y, z]))
    if node.scale is not None:
        M[:3, :3] = M[:3, :3] * np.asarray(node.scale, dtype=np.float64)
    if node.translation is not None:
        M[:3, 3] = node.translation
    return M


def _rest_trs(node: Any, path: Path, name: str) -> tuple[np.ndarray, np.ndarray]:
    """A joint node's rest translation and rotation (w, x, y, z); a scaled node is refused
    (a motion has no scale channels)."""
    M = _node_matrix(node)
    A = M[:3, :3]
    s = np.linalg.svd(A, compute_uv=False)
    if np.abs(s - 1).max() > 1e-4 or np.linalg.det(A) < 0:
        raise GLTFError(path, None, f"joint {name!r} is scaled; only rigid joints can be read")
    return M[:3, 3].copy(), rot.matrix_to_quat(A)


def _sample(times: np.ndarray, keys: np.ndarray, values: np.ndarray, interp: str, rotation: bool):
    """Values of a sampler at ``times`` (clamped to its keys): LINEAR (slerp for rotations),
    STEP, or CUBICSPLINE (its values at the keys, linear between them)."""
    if interp == "CUBICSPLINE":
        values = values.reshape(len(keys), 3, -1)[:, 1]
    if len(keys) == 1:
        return np.repeat(values[:1], len(times), 0)
    if len(keys) == len(times) and np.allclose(keys, times, atol=1e-5):
        return values.copy()
    i = np.clip(np.searchsorted(keys, times, side="right") - 1, 0, len(keys) - 2)
    span = np.where(keys[i + 1] > keys[i], keys[i + 1] - keys[i], 1.0)
    u = np.clip((times - keys[i]) / span, 0.0, 1.0)
    if interp == "STEP":
        u = (u >= 1.0).astype(np.float64)
    a, b = values[i], values[i + 1]
    if rotation:
        return rot.quat_slerp(a, b, u)
    return a + (b - a) * u[:, None]


def read_gltf(path: str | Path, animation: int = 0) -> Motion:
    """Read a skinned, animated glTF 2.0 file (``.glb`` or ``.gltf``) as a Motion in its own
    frame (metres, +Y up; ``metres_per_unit`` is 1).

    mocapkit's own files come back with their exact frame time, channel layout and End Sites.
    Other files: the first skin's joints (one root) with their rest translations as offsets and
    the ``animation``-th animation sampled at a constant rate (that of its densest sampler);
    leaf joints that no channel animates become End Sites only in mocapkit's files.
    """
    import pygltflib

    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise GLTFError(path, None, f"cannot read file: {e.strerror or e}") from None
    try:
        if data[:4] == b"glTF":
            if len(data) < 12:
                raise ValueError("truncated GLB header")
            length = struct.unpack("<I", data[8:12])[0]
            if length > len(data):
                raise ValueError(f"GLB says {length} bytes, the file has {len(data)}")
            gltf = pygltflib.GLTF2.load_from_bytes(data)
        else:
            gltf = pygltflib.GLTF2.gltf_from_json(data.decode("utf-8"))
        if gltf is None:
            raise ValueError("no JSON chunk")
    except (ValueError, KeyError, TypeError, struct.error, UnicodeDecodeError, OSError) as e:
        kind = "GLB" if data[:4] == b"glTF" else "glTF JSON"
        msg = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise GLTFError(path, None, f"not a readable {kind} file ({msg})") from None
    if not gltf.skins:
        raise GLTFError(path, None, "no skin (skeleton) in this glTF file; expected a rig")
    bufs = _buffers(gltf, path)
    extras = gltf.extras.get("mocapkit") if isinstance(gltf.extras, dict) else None
    ours = isinstance(extras, dict) and extras.get("format") == FORMAT

    nodes = gltf.nodes or []
    skin_joints = list(gltf.skins[0].joints or [])
    if not skin_joints or any(not 0 <= k < len(nodes) for k in skin_joints):
        raise GLTFError(path, None, "the skin's joints do not name nodes")
    parent_of: dict[int, int] = {}
    for k, node in enumerate(nodes):
        for c in node.children or []:
            parent_of[c] = k
    in_skin = set(skin_joints)
    roots = [k for k in skin_joints if parent_of.get(k) not in in_skin]
    if len(roots) != 1:
        raise GLTFError(path, None, f"the skin has {len(roots)} root joints; expected one")
    order: list[int] = []  # depth first: parents before children, children in file order
    stack = [roots[0]]
    while stack:
        k = stack.pop()
        order.append(k)
        stack.extend(c for c in reversed(nodes[k].children or []) if c in in_skin)
    if len(order) != len(in_skin):
        raise GLTFError(path, None, "the skin's joints are not one connected hierarchy")
    pos_in_skin = {k: i for i, k in enumerate(skin_joints)}
    if skin_joints[0] == roots[0] and all(
        pos_in_skin[parent_of[k]] < pos_in_skin[k] for k in skin_joints[1:]
    ):
        order = skin_joints  # the skin's own order when parents come first (mocapkit's do)
    index = {k: i for i, k in enumerate(order)}

    # the root's parents (an "Armature" node) move the whole character: fold them into it
    above = np.eye(4)
    k = parent_of.get(roots[0])
    seen: set[int] = set()
    while k is not None and k not in seen:
        seen.add(k)
        above = _node_matrix(nodes[k]) @ above
        k = parent_of.get(k)
    if np.abs(np.linalg.svd(above[:3, :3], compute_uv=False) - 1).max() > 1e-4:
        raise GLTFError(path, None, "the skeleton's parent node is scaled; cannot read it")

    N = len(order)
    names = [nodes[k].name or f"joint{i}" for i, k in enumerate(order)]
    parents = np.array([index[parent_of[k]] if i else -1 for i, k in enumerate(order)])
    rest_t = np.zeros((N, 3))
    rest_q = np.zeros((N, 4))
    for i, k in enumerate(order):
        rest_t[i], rest_q[i] = _rest_trs(nodes[k], path, names[i])

    anims = gltf.animations or []
    rot_keys: dict[int, tuple[np.ndarray, np.ndarray, str]] = {}
    pos_keys: dict[int, tuple[np.ndarray, np.ndarray, str]] = {}
    if anims:
        if not 0 <= animation < len(anims):
            raise GLTFError(path, None, f"no animation {animation} (the file has {len(anims)})")
        anim = anims[animation]
        for ch in anim.channels or []:
            node = ch.target.node if ch.target else None
            if node not in index or ch.target.path not in ("rotation", "translation"):
                continue
            s = anim.samplers[ch.sampler]
            keys = _accessor(gltf, bufs, s.input, path)[:, 0]
            vals = _accessor(gltf, bufs, s.output, path)
            interp = s.interpolation or "LINEAR"
            target = rot_keys if ch.target.path == "rotation" else pos_keys
            target[index[node]] = (keys, vals, interp)

    all_keys = [v[0] for v in (*rot_keys.values(), *pos_keys.values())]
    if ours:
        frame_time = float(extras["frame_time"])
        F = int(extras.get("frames", max((len(k) for k in all_keys), default=0)))
    elif all_keys:
        dense = max(all_keys, key=len)
        steps = np.diff(dense)
        frame_time = float(np.median(steps)) if len(steps) else 1.0 / 30.0
        if not frame_time > 0:
            raise GLTFError(path, None, "animation key times do not increase")
        start, stop = min(k[0] for k in all_keys), max(k[-1] for k in all_keys)
        F = round(float(stop - start) / frame_time) + 1
    else:
        frame_time, F = 1.0 / 30.0, 1
    t0 = min((k[0] for k in all_keys), default=0.0)
    times = t0 + np.arange(F) * frame_time

    rotations = np.repeat(rest_q[None], F, 0)
    trans = np.repeat(rest_t[None], F, 0)
    try:
        for i, (keys, vals, interp) in rot_keys.items():
            q = vals[:, [3, 0, 1, 2]] if interp != "CUBICSPLINE" else vals
            if interp == "CUBICSPLINE":
                q = vals.reshape(len(keys), 3, 4)[:, 1][:, [3, 0, 1, 2]]
                interp = "LINEAR"
            rotations[:, i] = rot.quat_normalize(_sample(times, keys, q, interp, True))
        for i, (keys, vals, interp) in pos_keys.items():
            trans[:, i] = _sample(times, keys, vals, interp, False)
    except ValueError as e:
        raise GLTFError(path, None, f"animation samplers do not fit their keys: {e}") from None
    # fold the root's parent transform in (rigid)
    A, b = above[:3, :3], above[:3, 3]
    rotations[:, 0] = rot.quat_mul(rot.matrix_to_quat(A), rotations[:, 0])
    trans[:, 0] = trans[:, 0] @ A.T + b

    # mocapkit's End Sites come back as End Sites
    end = np.zeros(N, bool)
    es_names: list[str] = []
    if ours and isinstance(extras.get("end_site_names"), list):
        E = len(extras["end_site_names"])
        if 0 < E < N:
            end_nodes = set(skin_joints[len(skin_joints) - E :])
            end = np.array([k in end_nodes for k in order])
            es_names = [str(n) for n in extras["end_site_names"]]
    keep = np.flatnonzero(~end)
    if np.any(np.isin(parents[keep], np.flatnonzero(end))):
        raise GLTFError(path, None, "an End Site has children")
    new_index = -np.ones(N, int)
    new_index[keep] = np.arange(len(keep))
    J = len(keep)
    moving = np.zeros(J, bool)
    for i in pos_keys:
        if not end[i]:
            moving[new_index[i]] = True
    channels: list[tuple[str, ...]]
    ch_extra = extras.get("channels") if ours else None
    if isinstance(ch_extra, list) and len(ch_extra) == J:
        channels = [tuple(str(c) for c in ch) for ch in ch_extra]
    else:
        rot3 = ("Zrotation", "Xrotation", "Yrotation")
        channels = [
            (*POSITION_CHANNELS, *rot3) if (j == 0 or moving[j]) else rot3 for j in range(J)
        ]
    end_idx = np.flatnonzero(end)
    if es_names and len(es_names) != len(end_idx):
        es_names = []
    try:
        skeleton = Skeleton(
            tuple(names[i] for i in keep),
            np.where(parents[keep] < 0, -1, new_index[parents[keep]]),
            rest_t[keep],
            tuple(channels),
            new_index[parents[end_idx]],
            rest_t[end_idx],
            tuple(es_names) if es_names else ("",) * len(end_idx),
            1.0,
        )
    except ValueError as e:
        raise GLTFError(path, None, f"not a usable skeleton: {e}") from None
    sk_has_pos = skeleton.has_position
    any_moving = bool(np.any(sk_has_pos[1:]))
    motion = Motion(
        skeleton,
        rotations[:, keep],
        trans[:, keep[0]],
        frame_time,
        trans[:, keep] if any_moving else None,
    )
    try:
        motion.check_finite(str(path))
    except ValueError as e:
        raise GLTFError(path, None, str(e)) from None
    return motion
