"""Regenerates the fuzzing seed corpus (corpus/) and the hand-made malformed files
(malformed/, with expected_errors.txt) replayed by tests/io/test_parser_corpus.cpp. Each
folder is named after its parser in parsers.h.
Run with Debian's Python: /usr/bin/python3 tests/fuzz/make_corpus.py"""
import io
import json
import os
import shutil
import struct
import zlib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def safetensors(header, data=b"", pad=True):
    text = header if isinstance(header, bytes) else json.dumps(header, separators=(",", ":")).encode()
    if pad:
        text += b" " * (-len(text) % 8)
    return struct.pack("<Q", len(text)) + text + data


def tensor(dtype, shape, begin, end):
    return {"dtype": dtype, "shape": shape, "data_offsets": [begin, end]}


def npy(array):
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def npy_raw(header, data=b""):
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header + data


def ply_binary(points, colors=None, extra=b""):
    header = b"ply\nformat binary_little_endian 1.0\ncomment seed\nelement vertex %d\n" % len(points)
    header += b"property float x\nproperty float y\nproperty float z\n"
    if colors:
        header += b"property uchar red\nproperty uchar green\nproperty uchar blue\n"
    header += extra + b"end_header\n"
    data = b""
    for i, p in enumerate(points):
        data += struct.pack("<3f", *p) + (bytes(colors[i]) if colors else b"")
    return header + data


def f32(*values):
    return struct.pack("<%df" % len(values), *values)


# Hypersim's metadata_camera_parameters.csv (contrib/mikeroberts3000): the standard camera and a
# tilt-shift one, with a few of its other columns.
HYPERSIM_CAMERAS = (b"scene_name,settings_output_img_height,settings_output_img_width,settings_units_info_meters_scale,"
                    b"use_camera_physical,M_cam_from_uv_00,M_cam_from_uv_01,M_cam_from_uv_02,M_cam_from_uv_10,"
                    b"M_cam_from_uv_11,M_cam_from_uv_12,M_cam_from_uv_20,M_cam_from_uv_21,M_cam_from_uv_22\n"
                    b"ai_001_001,768.0,1024.0,0.02539999969303608,False,0.5773502886169104,0.0,0.0,0.0,"
                    b"0.4330127164626828,0.0,0.0,0.0,-1.0\n"
                    b"ai_038_009,768.0,1024.0,0.02539999969303608,False,0.6088745353317421,0.0,-0.04870996173778685,"
                    b"0.0,0.42281668362380326,-0.11275110051191127,-0.0,-0.17251279495462457,-1.0546015951381162\n")

def png_chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png(text=(), itxt=(), width=2, height=2):
    """A 16-bit grey PNG with tEXt (and uncompressed iTXt) chunks, as MoGe's depth.png."""
    rows = b"".join(b"\x00" + struct.pack(">%dH" % width, *range(y, y + width)) for y in range(height))
    body = png_chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 16, 0, 0, 0, 0))
    for key, value in text:
        body += png_chunk(b"tEXt", key + b"\x00" + value)
    for key, value in itxt:
        body += png_chunk(b"iTXt", key + b"\x00\x00\x00en\x00" + key + b"\x00" + value)
    body += png_chunk(b"IDAT", zlib.compress(rows)) + png_chunk(b"IEND", b"")
    return b"\x89PNG\r\n\x1a\n" + body


def js(value):
    return json.dumps(value, indent=1).encode()


def jsonl(value):  # one line of a JSON-lines file
    return json.dumps(value).encode() + b"\n"


# A car's rig (io/rig.h): a forward pinhole looking along the body's x axis (camera z -> body x,
# camera x -> -body y, camera y -> -body z), a MEI fisheye looking left, a KITTI LiDAR.
RIG_FRONT = {"name": "front", "camera": "PINHOLE 1920 1080 1000 1000 959.5 539.5",
             "body_from_camera": [[0, 0, 1, 1.5], [-1, 0, 0, 0], [0, -1, 0, 1.2]]}
RIG = {"frame": "body",
       "cameras": [RIG_FRONT,
                   {"name": "left", "camera": "MEI 1400 1400 600 600 699.5 699.5 0.9 0 0 0 0",
                    "body_from_camera": [[1, 0, 0, 0.5], [0, 0, 1, 0.9], [0, -1, 0, 1.0], [0, 0, 0, 1]]}],
       "lidar": {"format": "kitti", "body_from_lidar": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1.7]]}}


def lzf_literals(data):
    """LZF data of literal runs only (a control byte n < 32, then n + 1 bytes)."""
    return b"".join(bytes([len(data[i:i + 32]) - 1]) + data[i:i + 32] for i in range(0, len(data), 32))


def pcd_header(fields, sizes, types, counts, points, data, viewpoint="0 0 0 1 0 0 0"):
    lines = ["# .PCD v0.7 - Point Cloud Data file format", "VERSION 0.7", "FIELDS " + " ".join(fields),
             "SIZE " + " ".join(map(str, sizes)), "TYPE " + " ".join(types)]
    if counts:
        lines.append("COUNT " + " ".join(map(str, counts)))
    lines += ["WIDTH %d" % points, "HEIGHT 1"]
    if viewpoint:
        lines.append("VIEWPOINT " + viewpoint)
    lines += ["POINTS %d" % points, "DATA " + data]
    return ("\n".join(lines) + "\n").encode()


XYZ_RGB = (["x", "y", "z", "rgb"], [4, 4, 4, 4], ["F", "F", "F", "U"], [1, 1, 1, 1])
PCD_POINTS = [(1.5, -2, 3, 0xff8000), (float("nan"), float("nan"), float("nan"), 0), (0, 0.25, -8, 7)]


def pcd_binary(points=PCD_POINTS):
    return pcd_header(*XYZ_RGB, len(points), "binary") + b"".join(struct.pack("<3fI", *p) for p in points)


def pcd_compressed(points=PCD_POINTS, sizes=None):
    data = b"".join(struct.pack("<%d%s" % (len(points), t), *[p[i] for p in points]) for i, t in enumerate("fffI"))
    compressed = lzf_literals(data)
    sizes = sizes or (len(compressed), len(data))
    return pcd_header(*XYZ_RGB, len(points), "binary_compressed") + struct.pack("<II", *sizes) + compressed


PCD_ASCII = pcd_header(*XYZ_RGB, 3, "ascii") + b"1.5 -2 3 16744448\nnan nan nan 0\n0 0.25 -8 7\n"
# Two points (1, 1, 1): six equal floats, one literal and one back reference of 20 bytes.
PCD_BACKREF = (pcd_header(["x", "y", "z"], [4, 4, 4], ["F", "F", "F"], None, 2, "binary_compressed", None)
               + struct.pack("<II", 8, 24) + b"\x03" + struct.pack("<f", 1) + b"\xe0\x0b\x03")
PCD_TYPES = (pcd_header(["intensity", "x", "y", "z", "hist"], [1, 8, 2, 4, 4], ["U", "F", "I", "U", "F"],
                        [1, 1, 1, 1, 3], 1, "binary", None)
             + struct.pack("<BdhI3f", 9, -0.5, -3, 70000, 0, 1, 2))


# COLMAP models as COLMAP writes them (src/colmap/scene/reconstruction_io_{text,binary}.cc).
COLMAP_MODEL_IDS = {"SIMPLE_PINHOLE": 0, "PINHOLE": 1, "SIMPLE_RADIAL": 2, "RADIAL": 3, "OPENCV": 4,
                    "OPENCV_FISHEYE": 5, "FULL_OPENCV": 6, "FOV": 7, "SIMPLE_RADIAL_FISHEYE": 8,
                    "RADIAL_FISHEYE": 9, "THIN_PRISM_FISHEYE": 10, "RAD_TAN_THIN_PRISM_FISHEYE": 11,
                    "SIMPLE_DIVISION": 12, "DIVISION": 13, "SIMPLE_FISHEYE": 14, "FISHEYE": 15, "EUCM": 16,
                    "EQUIRECTANGULAR": 17}
COLMAP_CAMERAS = [(1, "PINHOLE", 640, 480, [500, 510, 320, 240]),
                  (2, "OPENCV", 320, 240, [250, 250, 160, 120, -0.1, 0.01, 0.001, -0.001]),
                  (3, "EQUIRECTANGULAR", 64, 32, [64, 32])]
H = 0.5 ** 0.5
COLMAP_IMAGES = [(1, [H, 0, 0, H], [0.5, -0.5, 3], 1, "frames/one.jpg", [(345, 240, 7)]),
                 (2, [1, 0, 0, 0], [0, 0, 0], 2, "two.png", [(10.5, 20.25, -1), (160, 120, 8)]),
                 (3, [1, 0, 0, 0], [0, 0, 0], 3, "pano 1.jpg", [])]
COLMAP_POINTS = [(7, [0.5, 0.25, 2], [255, 128, 0], 0.5, [(1, 0)]), (8, [0, 0, 4], [1, 2, 3], 1.25, [(2, 1)])]


def colmap_cameras_txt(cameras=COLMAP_CAMERAS):
    text = "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
    text += "# Number of cameras: %d\n" % len(cameras)
    text += "".join("%d %s %d %d" % (i, m, w, h) + "".join(" %r" % p for p in params) + "\n"
                    for i, m, w, h, params in cameras)
    return text.encode()


def colmap_images_txt(images=COLMAP_IMAGES):
    text = ("# Image list with two lines of data per image:\n"
            "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
            "# Number of images: %d, mean observations per image: 1\n" % len(images))
    for i, q, t, camera, name, observations in images:
        text += " ".join(map(repr, [i] + q + t + [camera])) + " " + name + "\n"
        text += " ".join("%r %r %d" % o for o in observations) + "\n"
    return text.encode()


def colmap_points_txt(points=COLMAP_POINTS):
    text = ("# 3D point list with one line of data per point:\n"
            "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
            "# Number of points: %d, mean track length: 1\n" % len(points))
    for i, xyz, rgb, error, track in points:
        text += " ".join(map(repr, [i] + xyz + rgb + [error])) + " " + " ".join("%d %d" % e for e in track) + "\n"
    return text.encode()


def colmap_cameras_bin(cameras=COLMAP_CAMERAS, model_id=None):
    data = struct.pack("<Q", len(cameras))
    for i, m, w, h, params in cameras:
        data += struct.pack("<IiQQ", i, COLMAP_MODEL_IDS[m] if model_id is None else model_id, w, h)
        data += struct.pack("<%dd" % len(params), *params)
    return data


def colmap_images_bin(images=COLMAP_IMAGES, count=None):
    data = struct.pack("<Q", len(images) if count is None else count)
    for i, q, t, camera, name, observations in images:
        data += struct.pack("<I7dI", i, *q, *t, camera) + name.encode() + b"\x00"
        data += struct.pack("<Q", len(observations))
        data += b"".join(struct.pack("<2dQ", x, y, p % (1 << 64)) for x, y, p in observations)
    return data


def colmap_points_bin(points=COLMAP_POINTS, count=None):
    data = struct.pack("<Q", len(points) if count is None else count)
    for i, xyz, rgb, error, track in points:
        data += struct.pack("<Q3d3BdQ", i, *xyz, *rgb, error, len(track))
        data += b"".join(struct.pack("<II", *e) for e in track)
    return data


KITTI_RAW = (b"calib_time: 15-Mar-2012 11:37:16\n"
             b"R: 7.533745e-03 -9.999714e-01 -6.166020e-04 1.480249e-02 7.280733e-04 -9.998902e-01 "
             b"9.998621e-01 7.523790e-03 1.480755e-02\nT: -4.069766e-03 -7.631618e-02 -2.717806e-01\n"
             b"delta_f: 0.000000e+00 0.000000e+00\ndelta_c: 0.000000e+00 0.000000e+00\n")
KITTI_ODOMETRY = b"".join(b"P%d: 7.188560e+02 0 6.071928e+02 0 0 7.188560e+02 1.852157e+02 0 0 0 1 0\n" % i
                          for i in range(4)) + b"Tr: 4.2768e-04 -9.9997e-01 -8.0844e-03 -1.1984e-02 " \
                          b"-7.2106e-03 8.0811e-03 -9.9994e-01 -5.4039e-02 9.9997e-01 4.8594e-04 -7.2069e-03 " \
                          b"-2.9219e-01\n"


MINIMAL_TRAIN = {"model": {}, "data": {"datasets": [{"synth": {"cameras": ["PINHOLE 56 56 50 50 28 28"]}}]},
                 "stages": [{"stage": 1, "steps": 10}]}
FULL_TRAIN = {
    "output_dir": "runs/small", "seed": 3, "threads": 1, "model": {"conditioning": True},
    "init": {"from": "moge2", "path": "moge2.safetensors", "output": "xyz"},
    "data": {"batch_size": 8, "image_size": [64, 48], "num_tokens": [16, 32],
             "datasets": [{"weight": 1, "synth": {"scenes": ["indoor", "object"],
                                                  "cameras": ["PINHOLE 64 48 50 50 32 24"]}},
                          {"weight": 0.5, "folders": "data/samples"}]},
    "conditions": {"probability": 0.9, "sparse_ratio": [0.0005, 0.001]},
    "augment": {"p2a": True, "p2a_probability": 0.02, "a2p": True, "a2p_probability": 1,
                "a2p_teacher": "stage1.safetensors", "a2p_teacher_tokens": 0},
    "loss": {"point_loss": "naive", "align_trunc": 1,
             "weights": {"point": 1, "ray": 1, "metric": 1, "normal": 1, "local": 1, "mask": 1, "gauge": 0},
             "local": {"levels": [4, 16, 64], "patches_per_item": 16, "min_points": 32}},
    "optimizer": {"weight_decay": 0.01, "betas": [0.9, 0.999], "eps": 1e-8, "grad_clip": 1.0},
    "ema": {"decay": 0.999},
    "stages": [{"stage": 1, "steps": 1e4, "lr_backbone": 1e-4, "lr_heads": 1e-5, "decay_every": 2000,
                "decay_factor": 0.5}, {"stage": 2, "steps": 5}, {"stage": 3, "steps": 5}],
    "checkpoint_every": 500, "log_every": 10, "eval_every": 0, "eval_batches": 4, "max_nonfinite_steps": 10}
ROOT = os.path.dirname(os.path.dirname(HERE))


def safetensors_metadata(path):
    """The "__metadata__" of a .safetensors file (its header's JSON)."""
    with open(os.path.join(ROOT, path), "rb") as f:
        length = struct.unpack("<Q", f.read(8))[0]
        return json.loads(f.read(length))["__metadata__"]


# Model configs as checkpoints carry them (safetensors metadata "config"): the bundled model's,
# the tiny example's, MoGe-2's from the fixture (README there) and in its published form (a hub
# backbone, an int of intermediate layers, no scale head, a key MoGe takes as **kwargs).
BUNDLED_CONFIG = safetensors_metadata("models/omnipoint_default.safetensors")["config"].encode()
BUNDLED = json.loads(BUNDLED_CONFIG)
MOGE2_CONFIG = safetensors_metadata("tests/fixtures/moge2_forward_a/model.safetensors")["config"].encode()
MOGE2 = json.loads(MOGE2_CONFIG)
with open(os.path.join(ROOT, "examples/models/tiny_omnipoint.json"), "rb") as f:
    TINY_CONFIG = f.read()
TINY = json.loads(TINY_CONFIG)
TINY_XYZ = dict({k: v for k, v in TINY.items() if k not in ("ray_head", "distance_head")},
                output="xyz", points_head=dict(TINY["ray_head"]))
MOGE2_HUB = dict(MOGE2, encoder={"backbone": "dinov2_vits14", "intermediate_layers": 4, "dim_out": 64},
                 normal_head=MOGE2["points_head"], scale_head=None, trained_area_range=[250000, 500000])


def changed(config, path, value):
    """`config` with the entry at `path` (keys and indices) set to `value`, or deleted (None)."""
    config = json.loads(json.dumps(config))
    at = config
    for key in path[:-1]:
        at = at[key]
    if value is None:
        del at[path[-1]]
    else:
        at[path[-1]] = value
    return js(config)


K = [[0.75, 0, 0.5], [0, 1.0, 0.5], [0, 0, 1]]
IDENTITY_4X4 = b"1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n"
NEAR_FAR = ((b"near", b"0.5"), (b"far", b"80.25"))

# PyTorch checkpoints (torch.save's zip) and bare pickles as torch.save writes them (data.pkl).
def torch_checkpoint(obj, **options):
    import torch
    buffer = io.BytesIO()
    torch.save(obj, buffer, **options)
    return buffer.getvalue()


def data_pkl(checkpoint):
    import zipfile
    with zipfile.ZipFile(io.BytesIO(checkpoint)) as archive:
        return archive.read([n for n in archive.namelist() if n.endswith("/data.pkl")][0])


def checkpoint_seeds():
    import collections
    import torch
    torch.manual_seed(0)
    state = collections.OrderedDict([("blocks.0.weight", torch.randn(2, 3)), ("bias", torch.randn(3).half()),
                                     ("steps", torch.tensor([3, -1])), ("mask", torch.tensor([True, False]))])
    base = torch.randn(3, 4)
    views = {"t": base.t(), "slice": base[1:, 2:], "bf16": torch.ones(2, dtype=torch.bfloat16)}
    moge = {"model_config": {"encoder": {"backbone": "dinov2_vits14", "intermediate_layers": [2, 5]},
                             "remap_output": "exp", "num_tokens_range": [1200, 3600], "scale": 1.5, "x": None},
            "model": state}
    seeds = {"state_dict.pt": torch_checkpoint(state), "views.pt": torch_checkpoint(views),
             "moge.pt": torch_checkpoint(moge), "moge_p4.pt": torch_checkpoint(moge, pickle_protocol=4)}
    seeds.update({name.replace(".pt", ".pkl"): data_pkl(data) for name, data in list(seeds.items())})
    return seeds


def pickle_global(module, name, argument):
    """A pickle that calls module.name(argument), as an attacker would write it."""
    text = argument.encode()
    return (b"\x80\x02c" + module.encode() + b"\n" + name.encode() + b"\n(X" + struct.pack("<I", len(text)) + text
            + b"tR.")


KITTI_CAM_TO_CAM = (b"calib_time: 09-Jan-2012 13:57:47\ncorner_dist: 9.950000e-02\n"
                    b"S_rect_00: 1.242000e+03 3.750000e+02\n"
                    b"R_rect_00: 9.999239e-01 9.837760e-03 -7.445048e-03 -9.869795e-03 9.999421e-01 "
                    b"-4.278459e-03 7.402527e-03 4.351614e-03 9.999631e-01\n"
                    b"S_rect_02: 1.242000e+03 3.750000e+02\n"
                    b"P_rect_02: 7.215377e+02 0.000000e+00 6.095593e+02 4.485728e+01 0.000000e+00 "
                    b"7.215377e+02 1.728540e+02 2.163791e-01 0.000000e+00 0.000000e+00 1.000000e+00 "
                    b"2.745884e-03\n")
KITTI360_FISHEYE = (b"%YAML:1.0\nmodel_type: MEI\ncamera_name: image_02\nimage_width: 1400\n"
                    b"image_height: 1400\nmirror_parameters:\n   xi: 2.2134047507854890e+00\n"
                    b"distortion_parameters:\n   k1: 1.6798235660113681e-02\n   k2: 1.6548773243373522e+00\n"
                    b"   p1: 4.2223943394772046e-04\n   p2: 4.2462134260997584e-04\n"
                    b"projection_parameters:\n   gamma1: 1.3363220825849971e+03\n"
                    b"   gamma2: 1.3357883350012958e+03\n   u0: 7.1694323510126321e+02\n"
                    b"   v0: 7.0576498308221585e+02\n")
SUITE_SET = {"name": "A", "group": "360\u00b0", "format": "stanford2d3d", "root": "Stanford2D3D",
             "split": "splits/a.txt", "options": {"sequence": "area_5a"}, "modes": ["none", "+K"]}
SUITE = {"name": "s", "columns": {"depth": "depth_affine_invariant"}, "sets": [SUITE_SET]}


def suite_with(**changes):
    return js(dict(SUITE, sets=[dict(SUITE_SET, **changes)]))


SEEDS = {
    "safetensors/empty.safetensors": safetensors({}),
    "safetensors/metadata_only.safetensors": safetensors({"__metadata__": {"format": "moge2", "config": "{}"}}),
    "safetensors/f32.safetensors": safetensors({"w": tensor("F32", [2, 2], 0, 16)}, np.arange(4, dtype="<f4").tobytes()),
    "safetensors/mixed.safetensors": safetensors(
        {"__metadata__": {"format": "test"}, "i": tensor("I64", [1], 0, 8), "f": tensor("F32", [1], 8, 12),
         "h": tensor("BF16", [2], 12, 16), "b": tensor("BOOL", [2], 16, 18), "u": tensor("U8", [], 18, 19),
         "z": tensor("F16", [0, 4], 19, 19)},
        struct.pack("<q", -5) + struct.pack("<f", 1.5) + b"\x80\x3f\x00\x40" + b"\x01\x00" + b"\x07"),
    "safetensors/f64_i32.safetensors": safetensors(
        {"d": tensor("F64", [1], 0, 8), "n": tensor("I32", [1, 1], 8, 12), "s": tensor("I16", [1], 12, 14),
         "c": tensor("I8", [2], 14, 16)},
        struct.pack("<d", 0.25) + struct.pack("<i", 3) + struct.pack("<h", -2) + b"\x01\xff"),
    "npy/f4.npy": npy(np.arange(6, dtype="<f4").reshape(2, 3)),
    "npy/f8_scalar.npy": npy(np.float64(2.5)),
    "npy/u1.npy": npy(np.array([[0, 1], [1, 0]], dtype=np.uint8)),
    "npy/b1.npy": npy(np.array([True, False])),
    "npy/i4_empty.npy": npy(np.zeros((0, 3), dtype="<i4")),
    "npy/i8.npy": npy(np.array([1, -1], dtype="<i8")),
    "ply/binary_xyz.ply": ply_binary([(0, 0, 1), (1.5, -2, 3)]),
    "ply/binary_rgb.ply": ply_binary([(0, 0, 1), (1, 2, 3)], [(255, 0, 7), (1, 2, 3)]),
    "ply/binary_face.ply": ply_binary([(0, 0, 1)], extra=b"element face 0\nproperty list uchar int vertex_indices\n"),
    "ply/ascii_xyz.ply": b"ply\r\nformat ascii 1.0\r\nelement vertex 2\r\nproperty float x\r\n"
                         b"property float y\r\nproperty float z\r\nend_header\r\n0 0 1\r\n-1.5e2 2 .5\r\n",
    "ply/ascii_types.ply": b"ply\nformat ascii 1.0\nobj_info test\nelement vertex 1\nproperty double x\n"
                           b"property int16 intensity\nproperty double y\nproperty uint z\nproperty uchar red\n"
                           b"property uchar green\nproperty uchar blue\nelement face 1\nproperty list uchar int i\n"
                           b"end_header\n1 -7 2 3 10 20 30\n3 0 1 2\n",
    "ply/binary_types.ply": b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty char a\n"
                            b"property int8 b\nproperty short c\nproperty ushort d\nproperty int32 e\n"
                            b"property uint32 f\nproperty float64 x\nproperty float32 y\nproperty uint8 g\n"
                            b"property uint16 h\nproperty float z\nend_header\n"
                            + struct.pack("<bbhHiIdfBHf", -1, 2, -3, 4, -5, 6, 0.5, 1.5, 7, 8, 2.5),
    "ply/empty.ply": b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                     b"property float z\nend_header\n",
    "lidar_bin/one.bin": f32(1, 2, 3, 0.5),
    "lidar_bin/three.bin": f32(1, 2, 3, 0.5, -4, 5.5, 0, 1, 1e3, -1e-3, 2, 0),
    "lidar_bin/nuscenes_four.bin": f32(*range(20)),
    "pcd/ascii.pcd": PCD_ASCII,
    "pcd/binary.pcd": pcd_binary(),
    "pcd/binary_compressed.pcd": pcd_compressed(),
    "pcd/backref.pcd": PCD_BACKREF,
    "pcd/types.pcd": PCD_TYPES,
    "pcd/empty.pcd": pcd_header(*XYZ_RGB, 0, "binary"),
    "colmap/cameras.txt": colmap_cameras_txt(),
    "colmap/cameras.bin": colmap_cameras_bin(),
    "colmap/cameras_models.txt": b"1 SIMPLE_PINHOLE 64 48 50 32 24\n2 SIMPLE_RADIAL 64 48 50 32 24 0.1\n"
                                 b"3 RADIAL 64 48 50 32 24 0.1 0.01\n4 FULL_OPENCV 64 48 50 50 32 24 0 0 0 0 0 0 0 0\n"
                                 b"5 FOV 64 48 50 50 32 24 0.9\n6 OPENCV_FISHEYE 64 48 50 50 32 24 0 0 0 0\n"
                                 b"7 EUCM 64 48 50 50 32 24 0.5 1\n8 EQUIRECTANGULAR 64 32\n",
    "colmap/images.txt": colmap_images_txt(),
    "colmap/images.bin": colmap_images_bin(),
    "colmap/points3D.txt": colmap_points_txt(),
    "colmap/points3D.bin": colmap_points_bin(),
    "rigid_transform/identity.txt": IDENTITY_4X4,
    "rigid_transform/kitti_raw.txt": KITTI_RAW,
    "rigid_transform/kitti_odometry.txt": KITTI_ODOMETRY,
    "rigid_transform/kitti_3x4.txt": b"7.5e-03,-9.9e-01,-6.1e-04,-4.0e-03,1.4e-02,7.2e-04,-9.9e-01,-7.6e-02,"
                                     b"9.9e-01,7.5e-03,1.4e-02,-2.7e-01\n",
    "rigid_transform/tabs.txt": b"\t1\t0\t0\t0.5\n 0 1 0 -0.25\n0 0 1 +1.0\n0 0 0 1",
    "rig/car.json": js(RIG),
    "rig/json_camera.json": js({"cameras": [{"name": "pano", "camera": {"model": "EQUIRECTANGULAR", "width": 64,
                                                                       "height": 32, "params": []},
                                             "body_from_camera": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]}]}),
    "native_text/2d3ds.txt": b"area_5a/pano/rgb/camera_0a_office_1_frame_equirectangular_domain_rgb.png "
                             b"area_5a/pano/depth/camera_0a_office_1_frame_equirectangular_domain_depth.png\n",
    "native_text/matterport3d_test.txt": b"# UniFuse\r\n17DRP5sb8fy/pano_skybox_color/0b22.jpg 17DRP5sb8fy/pano_depth/0b22.png\r\n\n",
    "native_text/dac_m3d.txt": b"2t7WUuJeko7/0_spherical_1_emission_center_0.png "
                               b"2t7WUuJeko7/0_spherical_1_depth_center_0.exr 162.97\n",
    "native_text/camera_pose.txt": b"-1083.7 2450.2 1400.0 0.98 -0.17 0.0 0.0 0.0 1.0 0.6 0.48 1\n",
    "native_text/intrinsic.txt": b"frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]\n0 0 725.0087 725.0087 620.5 187\n"
                                 b"0 1 725.0087 725.0087 620.5 187\n1 0 725.0087 725.0087 620.5 187\n",
    "native_text/metadata_camera_parameters.csv": HYPERSIM_CAMERAS,
    "native_text/metadata_images_split_scene_v1.csv": b"scene_name,camera_name,frame_id,included_in_public_release,"
                                                       b"exclude_reason,split_partition_name\n"
                                                       b"ai_001_001,cam_00,0,True,,train\n"
                                                       b"ai_001_001,cam_00,1,False,corrupt,train\n"
                                                       b"ai_038_009,cam_00,0,True,,val\n",
    "native_text/41069021_6845.873.pincam": b"256 192 211.949 211.949 127.933 95.9333\n",
    "camera/line.txt": b"PINHOLE 640 480 500 500 320 240\n",
    "camera/cameras.txt": b"# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
                          b"1 SIMPLE_RADIAL 320 240 250 160 120 -0.05\n\n"
                          b"2 OPENCV 640 480 500 501 320 240 -0.1 0.01 0.001 -0.001\n"
                          b"3 OPENCV_FISHEYE 640 480 300 300 320 240 0.1 0.01 0 0\n"
                          b"4 EQUIRECTANGULAR 64 32\n",
    "camera/fisheyes.txt": b"1 FOV 640 480 300 300 320 240 0.9\n2 MEI 640 480 300 300 320 240 0.9 0 0 0 0\n"
                           b"3 UCM 640 480 300 300 320 240 0.6\n4 DOUBLE_SPHERE 640 480 300 300 320 240 -0.2 0.6\n"
                           b"5 EQUIRECTANGULAR 64 32 -1 1 -0.5 0.5\n6 SIMPLE_PINHOLE 64 48 50 32 24\n",
    "camera/camera.json": js({"model": "EQUIRECTANGULAR", "width": 64, "height": 32, "params": []}),
    "camera/pinhole.json": js({"model": "PINHOLE", "width": 64, "height": 48, "params": [50, 50.5, 32, 24]}),
    # predict's camera.json as written (predict/outputs.h), and UniK3D's camera JSON (unik3d.h).
    "camera/predict_camera.json": js({"camera": {"model": "OPENCV_FISHEYE", "width": 64, "height": 48,
                                                 "params": [20, 20.5, 32, 24, 0.01, 0, 0, 0]},
                                      "camera_source": "fitted", "fit_residual_deg": {"median": 0.1, "max": 0.5},
                                      "camera_spec": "OPENCV_FISHEYE 64 48 20 20.5 32 24 0.01 0 0 0",
                                      "cameras_txt_line": "1 OPENCV_FISHEYE 64 48 20 20.5 32 24 0.01 0 0 0",
                                      "metric_scale": 1.0, "notes": []}),
    "camera/unik3d_spherical.json": js({"name": "Spherical",
                                        "params": [1.0, 1.0, 1.0, 1.0, 612.0, 277.0, 3.14159, 1.42192880719]}),
    "camera/unik3d_fisheye624.json": js({"name": "Fisheye624", "width": 64, "height": 48,
                                         "params": [30, 30, 32, 24, 0.01, 0, 0, 0, 0.001, 0, 0.0004, 0, 0, 0, 0, 0]}),
    "eval_suite/paper_suite.json": open(os.path.join(ROOT, "benchmarks", "paper_suite.json"), "rb").read(),
    "eval_suite/minimal.json": js(SUITE),
    # A rig log's manifest, read in a scratch root holding image.png, lidar.bin, calib.txt and
    # cameras.txt (tests/fuzz/parsers.h): the camera as a spec, a file and a JSON object; the
    # transform as 12 and 16 numbers and as a file; the LiDAR formats by name and count.
    "rig_log/manifest.jsonl": b"".join(jsonl(line) for line in [
        {"image": "image.png", "camera": "PINHOLE 64 48 50 50 32 24", "lidar": "lidar.bin",
         "lidar_to_camera": [0, -1, 0, 0, 0, 0, -1, -0.08, 1, 0, 0, -0.27]},
        {"image": "image.png", "camera": "cameras.txt", "lidar": "lidar.bin",
         "lidar_to_camera": "calib.txt", "lidar_format": "nuscenes"},
        {"image": "image.png", "camera": {"model": "PINHOLE", "width": 64, "height": 48,
                                           "params": [50, 50, 32, 24]},
         "lidar": "lidar.bin", "lidar_to_camera": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1],
         "lidar_format": 6}]) + b"\r\n",
    "rig_log/test_split.jsonl": jsonl({"image": "image.png", "camera": "OPENCV_FISHEYE 64 48 30 30 32 24 0.1 0 0 0",
                                       "lidar": "lidar.bin", "lidar_to_camera": "calib.txt", "lidar_format": "kitti"}),
    "train_config/minimal.json": js(MINIMAL_TRAIN),
    "train_config/full.json": js(FULL_TRAIN),
    "checkpoint_metadata/omnipoint_default.json": BUNDLED_CONFIG,
    "checkpoint_metadata/tiny_omnipoint.json": TINY_CONFIG,
    "checkpoint_metadata/tiny_xyz.json": js(TINY_XYZ),
    "checkpoint_metadata/moge2_fixture.json": MOGE2_CONFIG,
    "checkpoint_metadata/moge2_hub.json": js(MOGE2_HUB),
    "png_text/moge_depth.png": png(NEAR_FAR),
    "png_text/unit_itxt.png": png(((b"near", b"1e-2"), (b"far", b"1e3"), (b"unit", b"0.001")),
                                  itxt=((b"Software", b"seed"),)),
    "png_text/itxt.png": png(((b"unit", b"2"),), itxt=NEAR_FAR),
    "moge_meta/meta.json": js({"intrinsics": K}),
    "moge_meta/extra.json": js({"intrinsics": K, "depth_unit": 1.0, "name": "scene_a"}),
    "sample_meta/line.json": js({"format": "omnipoint-sample-1", "camera": "PINHOLE 16 12 14 14 8 6", "metric": True}),
    "sample_meta/object.json": js({"camera": {"model": "EQUIRECTANGULAR", "width": 64, "height": 32, "params": []},
                                   "scene": {"kind": "indoor"}}),
    "sample_meta/unlabelled.json": js({"format": "omnipoint-sample-1", "camera": "PINHOLE 16 12 14 14 8 6",
                                       "metric": False, "labelled": False}),
    "sample_meta/fisheye.json": js({"camera": "OPENCV_FISHEYE 28 28 9 9 14 14 0 0 0 0", "metric": False}),
    "hub_model_info/moge2.json": js({"id": "Ruicheng/moge-2-vitl-normal", "sha": "b135031bae30b5ac2ae141a0e68717795ce38340",
                                     "siblings": [{"rfilename": ".gitattributes"}, {"rfilename": "README.md"},
                                                  {"rfilename": "model.pt"}]}),
    "hub_model_info/several.json": js({"id": "o/r", "siblings": [{"rfilename": "a/model.safetensors"},
                                                                 {"rfilename": "b.pth"}, {"rfilename": "c.json"}]}),
    "kitti_text/calib_cam_to_cam.txt": KITTI_CAM_TO_CAM,
    "kitti_text/image_02.yaml": KITTI360_FISHEYE,
    "kitti_text/perspective.txt": b"P_rect_00: 5.525500e+02 0.000000e+00 6.820500e+02 0.000000e+00 "
                                  b"0.000000e+00 5.525500e+02 2.387700e+02 0.000000e+00 0.000000e+00 "
                                  b"0.000000e+00 1.000000e+00 0.000000e+00\n"
                                  b"R_rect_00: 0.999974 -0.007141 -0.000089 0.007141 0.999969 -0.003247 "
                                  b"0.000112 0.003247 0.999995\nS_rect_00: 1.408000e+03 3.760000e+02\n",
    "kitti_text/calib_cam_to_pose.txt": b"image_00: 0.0371 -0.0986 0.9944 1.5752 0.9992 -0.0053 -0.0378 "
                                        b"0.0043 0.0090 0.9951 0.0983 -0.6500\n"
                                        b"image_02: 0.9995 0.0010 0.0308 0.7265 -0.0307 -0.0262 0.9992 "
                                        b"-0.1471 0.0018 -0.9997 -0.0262 -0.8627\n",
    "kitti_text/poses.txt": b"3 0.99 0.01 0 1.5 -0.01 0.99 0 2.5 0 0 1 3.5\n"
                            b"5 1 0 0 1.6 0 1 0 2.6 0 0 1 3.6\n",
    "kitti_text/kitti360_list_val.txt": b"data_2d_raw/2013_05_28_drive_0000_sync/image_02/data_rgb/0000000000.png "
                                        b"proj_depth/2013_05_28_drive_0000_sync/image_02/0000000000.png 1336.3221\n",
    "kitti_text/eigen_test_files.txt": b"2011_09_26/2011_09_26_drive_0002_sync 69 l\n"
                                       b"2011_09_26/2011_09_26_drive_0002_sync 54 r\n",
}


F32 = tensor("F32", [2], 0, 8)
MALFORMED = {  # name: (bytes, fragment the error message must contain)
    "safetensors/short.safetensors": (b"\x05\x00", "shorter than the 8-byte header length"),
    "safetensors/header_cap.safetensors": (struct.pack("<Q", 1 << 40) + b"{}", "exceeds the 100 MiB cap"),
    "safetensors/header_past_end.safetensors": (struct.pack("<Q", 64) + b"{}", "runs past the end of the file"),
    "safetensors/not_json.safetensors": (safetensors(b"{\"a\":"), "header is not valid JSON"),
    "safetensors/not_object.safetensors": (safetensors(b"[1]"), "header is not a JSON object"),
    "safetensors/bad_utf8.safetensors": (safetensors(b"{\"\xff\":1}"), "header is not valid JSON"),
    "safetensors/duplicate.safetensors": (
        safetensors(b'{"a":{"dtype":"F32","shape":[1],"data_offsets":[0,4]},'
                    b'"a":{"dtype":"F32","shape":[1],"data_offsets":[4,8]}}', bytes(8)), "duplicate key 'a' in the header"),
    "safetensors/missing_dtype.safetensors": (
        safetensors({"a": {"shape": [2], "data_offsets": [0, 8]}}, bytes(8)), "missing string field 'dtype'"),
    "safetensors/shape_string.safetensors": (
        safetensors({"a": {"dtype": "F32", "shape": "2", "data_offsets": [0, 8]}}, bytes(8)), "missing array field 'shape'"),
    "safetensors/negative_dim.safetensors": (
        safetensors({"a": tensor("F32", [-2], 0, 8)}, bytes(8)), "'shape' must hold non-negative integers"),
    "safetensors/offsets_three.safetensors": (
        safetensors({"a": {"dtype": "F32", "shape": [2], "data_offsets": [0, 4, 8]}}, bytes(8)),
        "missing field 'data_offsets' of two integers"),
    "safetensors/unknown_dtype.safetensors": (
        safetensors({"a": tensor("Q8", [2], 0, 2)}, bytes(2)), "unsupported dtype 'Q8'"),
    "safetensors/size_mismatch.safetensors": (
        safetensors({"a": tensor("F32", [3], 0, 8)}, bytes(8)), "need 12"),
    "safetensors/overflow.safetensors": (
        safetensors({"a": tensor("F64", [1 << 62, 4], 0, 8)}, bytes(8)), "is too large"),
    "safetensors/past_data.safetensors": (
        safetensors({"a": tensor("F32", [2], 4, 12)}, bytes(8)), "past the end of the data section"),
    "safetensors/overlap.safetensors": (
        safetensors({"a": F32, "b": tensor("F32", [1], 4, 8)}, bytes(8)), "tensors 'a' and 'b' overlap"),
    "safetensors/hole.safetensors": (
        safetensors({"a": tensor("F32", [1], 0, 4), "b": tensor("F32", [1], 8, 12)}, bytes(12)),
        "bytes [4, 8) of the data section belong to no tensor"),
    "safetensors/trailing.safetensors": (
        safetensors({"a": F32}, bytes(11)), "the last 3 bytes of the data section belong to no tensor"),
    "safetensors/metadata_number.safetensors": (
        safetensors({"__metadata__": {"format": 2}}), "'__metadata__' entry 'format' is not a string"),
    "safetensors/bool_byte.safetensors": (
        safetensors({"a": tensor("BOOL", [2], 0, 2)}, b"\x00\x02"), "BOOL data holds a byte other than 0 or 1"),
    "npy/no_magic.npy": (b"NUMPY\x01\x00", "magic"),
    "npy/truncated_header.npy": (npy(np.zeros(2, "<f4"))[:20], "truncated header"),
    "npy/short_data.npy": (npy(np.zeros(4, "<f4"))[:-3], "bytes"),
    "npy/big_endian.npy": (npy(np.zeros(2, ">f4")), "unsupported dtype"),
    "npy/fortran.npy": (npy(np.asfortranarray(np.zeros((2, 2), "<f4"))), "Fortran"),
    "npy/bad_dict.npy": (npy_raw(b"{'descr': '<f4', 'shape': (1,) }\n", bytes(4)), "lacks"),
    "npy/version9.npy": (b"\x93NUMPY\x09\x00" + bytes(8), "version"),
    "ply/not_ply.ply": (b"plx\nformat ascii 1.0\nend_header\n", "the file does not start with 'ply'"),
    "ply/big_endian.ply": (b"ply\nformat binary_big_endian 1.0\nelement vertex 0\nend_header\n",
                           "format 'binary_big_endian'"),
    "ply/list_vertex.ply": (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nend_header\n",
                            "list property in the vertex element"),
    "ply/truncated.ply": (ply_binary([(0, 0, 1), (1, 2, 3)])[:-5], "PLY file is truncated: 2 vertices"),
    "ply/bad_value.ply": (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                          b"property float z\nend_header\n1 2 zz\n", "has a bad or missing value 'zz'"),
    "ply/colour_300.ply": (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                           b"property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
                           b"end_header\n1 2 3 300 0 0\n", "has a colour outside 0..255"),
    "ply/no_z.ply": (b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nend_header\n",
                     "lacks one of the properties x, y, z"),
    "ply/no_end_header.ply": (b"ply\nformat ascii 1.0\nelement vertex 0\n", "no end_header line"),
    "ply/huge_count.ply": (b"ply\nformat ascii 1.0\nelement vertex 999999999999\nproperty float x\n"
                           b"property float y\nproperty float z\nend_header\n1 2 3\n", "999999999999 vertices declared"),
    "lidar_bin/five_bytes.bin": (b"12345", "5 bytes is not a multiple of 16"),
    "lidar_bin/empty.bin": (b"", "the .bin scan is empty"),
    "lidar_bin/twenty.bin": (f32(1, 2, 3, 4, 5), "20 bytes is not a multiple of 16 (4 float32 per point, x, y, z "
                             "first); would fit: --lidar-format nuscenes (20 bytes per point)"),
    "pcd/no_data.pcd": (pcd_header(*XYZ_RGB, 3, "ascii").replace(b"DATA ascii\n", b""),
                        "no DATA line in the first 64 KiB"),
    "pcd/viewpoint.pcd": (pcd_header(*XYZ_RGB, 0, "ascii", "0 0 0 0.7071 0.7071 0 0"), "VIEWPOINT is not the identity"),
    "pcd/truncated.pcd": (pcd_binary()[:-1], "3 POINTS of 16 bytes do not fit in the file (47 bytes)"),
    "pcd/ascii_short.pcd": (PCD_ASCII[:-12], "truncated: 2 data lines for 3 POINTS"),
    "pcd/compressed_size.pcd": (pcd_compressed(sizes=(99, 48)), "compressed size 99 but"),
    "pcd/uncompressed_size.pcd": (pcd_compressed(sizes=(len(lzf_literals(bytes(48))), 47)),
                                  "uncompressed size 47 (the 3 POINTS need 48)"),
    "pcd/huge_points.pcd": (pcd_header(*XYZ_RGB, 1 << 30, "binary_compressed") + struct.pack("<II", 2, 1 << 31) + b"\x00\x00",
                            "1073741824 POINTS of 16 bytes do not fit in LZF data (180 bytes)"),
    "pcd/count_x.pcd": (pcd_header(["x", "y", "z"], [4, 4, 4], ["F", "F", "F"], [2, 1, 1], 0, "binary"),
                        "the field x has COUNT 2 (expected 1)"),
    "pcd/type.pcd": (pcd_header(["x", "y", "z"], [4, 4, 4], ["F", "F", "D"], None, 0, "binary"),
                     "field z has TYPE D SIZE 4"),
    "colmap/cameras_unknown_id.bin": (colmap_cameras_bin(model_id=42), "unknown COLMAP camera model id 42"),
    "colmap/cameras_fisheye.txt": (b"1 FISHEYE 64 48 50 50 32 24\n", "COLMAP's camera model FISHEYE is not supported"),
    "colmap/cameras_params.txt": (b"1 PINHOLE 64 48 50 50 32\n", "PINHOLE expects 4 parameters"),
    "colmap/cameras_truncated.bin": (colmap_cameras_bin()[:-3], "truncated: camera 3's parameter 1"),
    "colmap/images_truncated.bin": (colmap_images_bin()[:-5], "truncated: the number of image 3's points2D"),
    "colmap/images_count.bin": (colmap_images_bin(count=1 << 62), "4611686018427387904 images declared at byte 0"),
    "colmap/images_quaternion.txt": (b"1 0 0 0 0 0 0 0 1 a.jpg\n\n", "image 1: the quaternion is zero or not finite"),
    "colmap/images_no_points.txt": (b"1 1 0 0 0 0 0 0 1 a.jpg\n", "image 1 has no POINTS2D line"),
    "colmap/images_pairs.txt": (b"1 1 0 0 0 0 0 0 1 a.jpg\n1 2 3 4\n", "POINTS2D holds 4 values"),
    "colmap/points3D_count.bin": (colmap_points_bin(count=1 << 40), "1099511627776 points declared"),
    "colmap/points3D_colour.txt": (b"1 0 0 1 1 2 300 0\n", "colour 300 is not 0..255"),
    "colmap/points3D_twice.txt": (b"1 0 0 1 1 2 3 0\n1 0 0 1 1 2 3 0\n", "the point id 1 appears twice"),
    "rigid_transform/nine.txt": (b"1 0 0 0 1 0 0 0 1", "expected 16 numbers (4x4) or 12 (3x4), got 9"),
    "rigid_transform/kitti_no_t.txt": (KITTI_RAW.replace(b"T:", b"t:"), "needs T (raw calib_velo_to_cam.txt) or Tr"),
    "rigid_transform/kitti_r_count.txt": (b"R: 1 0 0 0 1 0 0 0\nT: 0 0 0\n", "R: expected 9 numbers, got 8"),
    "rigid_transform/kitti_twice.txt": (KITTI_ODOMETRY + b"Tr: 1\n", "the key Tr appears twice"),
    "rigid_transform/kitti_line.txt": (b"R: 1 0 0 0 1 0 0 0 1\nT 0 0 0\n", "is not \"KEY: values\""),
    "rigid_transform/word.txt": (b"1 0 0 x0\n", "\"x0\" is not a number"),
    "rigid_transform/nan.txt": (IDENTITY_4X4.replace(b"1 0 0 0\n", b"nan 0 0 0\n", 1), "expected a finite 4x4"),
    "rigid_transform/overflow.txt": (IDENTITY_4X4.replace(b"1 0 0 0\n", b"1e999 0 0 0\n", 1),
                                     "\"1e999\" is not a number"),
    "rig/not_json.json": (b'{"cameras": [', "not JSON"),
    "rig/overflow.json": (b'{"cameras": [{"name": "a", "camera": "PINHOLE 4 4 2 2 2 2", "body_from_camera": -1e999}]}',
                          "not JSON"),
    "rig/no_cameras.json": (js({"cameras": []}), "cameras: expected a list of at least one camera"),
    "rig/duplicate_name.json": (js({"cameras": [RIG_FRONT, RIG_FRONT]}), "cameras[1].name: 'front' names another"),
    "rig/bad_name.json": (js({"cameras": [dict(RIG_FRONT, name="../front")]}), "cameras[0].name: expected letters"),
    "rig/not_orthonormal.json": (js({"cameras": [dict(RIG_FRONT, body_from_camera=[[1, 0.01, 0, 0], [0, 1, 0, 0],
                                                                                   [0, 0, 1, 0]])]}),
                                 "cameras[0].body_from_camera: the rotation is not orthonormal"),
    "rig/reflection.json": (js({"cameras": [dict(RIG_FRONT, body_from_camera=[[-1, 0, 0, 0], [0, 1, 0, 0],
                                                                              [0, 0, 1, 0]])]}),
                            "cameras[0].body_from_camera: the rotation is a reflection"),
    "rig/fourth_row.json": (js({"cameras": [dict(RIG_FRONT, body_from_camera=[[1, 0, 0, 0], [0, 1, 0, 0],
                                                                              [0, 0, 1, 0], [0, 0, 1, 1]])]}),
                            "cameras[0].body_from_camera: the fourth row must be [0, 0, 0, 1]"),
    "rig/bad_camera.json": (js({"cameras": [dict(RIG_FRONT, camera="PINHOLE 1920 1080 1000")]}),
                            "cameras[0].camera: PINHOLE expects 4 parameters"),
    "rig/lidar_format.json": (js(dict(RIG, lidar={"format": "velodyne", "body_from_lidar": RIG["lidar"]["body_from_lidar"]})),
                              "lidar.format: "),
    "rig/unknown_key.json": (js(dict(RIG, cameras=[dict(RIG_FRONT, pose=[])])), "cameras[0].pose: unknown key"),
    "native_text/four_fields.txt": (b"a.png b.png 1\na.png b.png 1 2\n", ":2: expected 1 to 3 fields"),
    "native_text/absolute.txt": (b"/data/a.png\n", "is not relative to the root"),
    "native_text/climbs.txt": (b"area_1/../../a.png\n", "climbs out of the root"),
    "native_text/nul.txt": (b"a\x00.png\n", "holds a NUL byte"),
    "native_text/camera_pose_short.txt": (b"0 0 0 0 1 0 0 0 1 0.6 0.48\n", "expected one line of 12 numbers"),
    "native_text/camera_pose_fov.txt": (b"0 0 0 0 1 0 0 0 1 1.6 0.48 1\n", "half-angles in (0, pi/2)"),
    "native_text/camera_pose_word.txt": (b"0 0 0 0 1 0 0 0 1 0.6 x 1\n", "\"x\" is not a number"),
    "native_text/intrinsic_header.txt": (b"0 0 725 725 620.5 187\n", "expected the header line"),
    "native_text/intrinsic_fields.txt": (b"frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]\n0 0 725 725 620.5\n",
                                         ":2: expected 6 fields"),
    "native_text/intrinsic_twice.txt": (b"frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]\n0 1 7 7 6 1\n0 1 7 7 6 1\n",
                                        ":3: frame 0 of camera 1 is given twice"),
    "native_text/metadata_camera_parameters_column.csv": (HYPERSIM_CAMERAS.replace(b"M_cam_from_uv_21", b"M_cam_from_uv_2x"),
                                                          ":1: no column M_cam_from_uv_21"),
    "native_text/metadata_camera_parameters_fields.csv": (HYPERSIM_CAMERAS.replace(b",-1.0546015951381162", b""),
                                                          ":3: expected 14 fields (as the header), got 13"),
    "native_text/metadata_camera_parameters_size.csv": (HYPERSIM_CAMERAS.replace(b"768.0", b"-768.0", 1),
                                                        "settings_output_img_height \"-768.0\" is not a non-negative integer"),
    "native_text/metadata_images_split_partition.csv": (b"scene_name,camera_name,frame_id,included_in_public_release,"
                                                        b"split_partition_name\nai_001_001,cam_00,0,True,holdout\n",
                                                        "split_partition_name \"holdout\" is not train, val or test"),
    "native_text/short.pincam": (b"256 192 211.9 211.9 127.9\n", "expected one line of 6 numbers"),
    "native_text/width.pincam": (b"256.5 192 211.9 211.9 127.9 95.9\n", "width \"256.5\" is not a whole number"),
    "native_text/focal.pincam": (b"256 192 0 211.9 127.9 95.9\n", "fx and fy must be positive"),
    "camera/unknown_model.txt": (b"1 NOPE 640 480 1 2 3\n", "unknown camera model 'NOPE'"),
    "camera/bad_json.json": (b'{"model": "PINHOLE", "width": 64', "not valid JSON"),
    "camera/comments_only.txt": (b"# nothing here\n\n", "contains no camera"),
    "camera/param_count.txt": (b"PINHOLE 640 480 500 500 320\n", "PINHOLE expects 4 parameters (fx fy cx cy), got 3"),
    "camera/not_a_line.txt": (b"# header\nhello world\n1 PINHOLE 640 480 500 500 320 240\n", "not a camera line"),
    "camera/json_size.json": (js({"model": "PINHOLE", "width": 0, "height": 48, "params": [1, 1, 3, 4]}),
                              "image size must be positive"),
    "camera/width_float.txt": (b"PINHOLE 640.5 480 500 500 320 240\n", "width must be an integer"),
    "camera/predict_no_camera.json": (js({"camera": None, "fit_error": "fit_camera_auto: needs at least 16 valid rays, got 3"}),
                                      "holds no camera (\"camera\": null; no camera was fitted: fit_camera_auto: needs"),
    "camera/unik3d_no_size.json": (js({"name": "Pinhole", "params": [500, 500, 320, 240]}),
                                   "UniK3D Pinhole: the file holds no image size"),
    "camera/unik3d_radial_tangential.json": (js({"name": "MEI", "width": 960, "height": 940,
                                                 "params": [890.9, 890.5, 477.8, 470.3, 0.0168, 1.6549, 0.00042, 0.00042, 2.2134]}),
                                             "both radial (k1 k2) and tangential (p1 p2) terms are non-zero"),
    "eval_suite/not_json.json": (b'{"sets": [', "not JSON"),
    "rig_log/not_object.jsonl": (b"[1, 2]\n", "line 1: not a JSON object"),
    "rig_log/empty.jsonl": (b"\n \r\n", "the manifest names no frame"),
    "rig_log/no_image.jsonl": (jsonl({"camera": "PINHOLE 64 48 50 50 32 24", "lidar": "lidar.bin",
                                   "lidar_to_camera": "calib.txt"}), "\"image\" must be a path (a string)"),
    "rig_log/climbs.jsonl": (jsonl({"image": "../image.png", "camera": "PINHOLE 64 48 50 50 32 24",
                                 "lidar": "lidar.bin", "lidar_to_camera": "calib.txt"}),
                             "\"image\": \"../image.png\" is not a path under the root"),
    "rig_log/missing_file.jsonl": (jsonl({"image": "image.png", "camera": "PINHOLE 64 48 50 50 32 24",
                                       "lidar": "sweep.bin", "lidar_to_camera": "calib.txt"}),
                                   "line 1: no file"),
    "rig_log/no_camera.jsonl": (jsonl({"image": "image.png", "lidar": "lidar.bin", "lidar_to_camera": "calib.txt"}),
                                "no \"camera\", and no camera option for all frames"),
    "rig_log/transform_count.jsonl": (jsonl({"image": "image.png", "camera": "PINHOLE 64 48 50 50 32 24",
                                          "lidar": "lidar.bin", "lidar_to_camera": [1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0]}),
                                      "expected 16 numbers (4x4) or 12 (3x4), got 11"),
    "rig_log/transform_text.jsonl": (jsonl({"image": "image.png", "camera": "PINHOLE 64 48 50 50 32 24",
                                         "lidar": "lidar.bin", "lidar_to_camera": [1, "0", 0]}),
                                     "\"lidar_to_camera\" holds \"0\", not a number"),
    "rig_log/lidar_format.jsonl": (jsonl({"image": "image.png", "camera": "PINHOLE 64 48 50 50 32 24",
                                       "lidar": "lidar.bin", "lidar_to_camera": "calib.txt",
                                       "lidar_format": "velodyne"}),
                                   "LiDAR format 'velodyne': expected kitti"),
    "eval_suite/no_sets.json": (js({"name": "s"}), "sets: missing"),
    "eval_suite/unknown_key.json": (js(dict(SUITE, bogus=1)), "bogus: unknown key"),
    "eval_suite/column.json": (js(dict(SUITE, columns={"points": "points"})),
                               "columns.points: \"points\" is no protocol entry"),
    "eval_suite/group.json": (suite_with(group="wide"), "sets[0].group: expected"),
    "eval_suite/format.json": (suite_with(format="nope"), "sets[0].format: \"nope\" is no dataset format"),
    "eval_suite/option.json": (suite_with(options={"camera": "image_02"}),
                               "sets[0].options.camera: format \"stanford2d3d\" has no such option"),
    "eval_suite/modes.json": (suite_with(modes=["+D"]), "sets[0].modes: must hold \"none\""),
    "eval_suite/mode_word.json": (suite_with(modes=["none", 3]), "sets[0].modes[1]: expected"),
    "eval_suite/root_absolute.json": (suite_with(root="/data"), "sets[0].root: must be relative"),
    "eval_suite/name_path.json": (suite_with(name="../x"), "sets[0].name: \"../x\" must not be a path"),
    "eval_suite/twice.json": (js(dict(SUITE, sets=[SUITE_SET, SUITE_SET])),
                              "sets[1].name: \"A\" is the name of an earlier set"),
    "train_config/not_json.json": (b'{"stages": [', "not valid JSON"),
    "train_config/unknown_key.json": (js(dict(MINIMAL_TRAIN, bogus=1)), "bogus: unknown key"),
    "train_config/threads_huge.json": (js(dict(MINIMAL_TRAIN, threads=1e300)), "threads: expected an integer in range"),
    "train_config/steps_fraction.json": (js(dict(MINIMAL_TRAIN, stages=[{"stage": 1, "steps": 1.5}])),
                                         "stages[0].steps: expected an integer in range"),
    "train_config/no_stages.json": (js({k: v for k, v in MINIMAL_TRAIN.items() if k != "stages"}),
                                    "expected a non-empty array of training stages"),
    "train_config/seed_negative.json": (js(dict(MINIMAL_TRAIN, seed=-1)), "seed: expected an integer in range"),
    "train_config/tokens_huge.json": (js(dict(MINIMAL_TRAIN, data=dict(MINIMAL_TRAIN["data"], num_tokens=[1, 1e30]))),
                                      "data.num_tokens[1]: expected an integer in range"),
    "train_config/camera.json": (js(dict(MINIMAL_TRAIN, data={"datasets": [{"synth": {"cameras": ["PINHOLE 56 56 0 50 28 28"]}}]})),
                                 "data.datasets[0].synth.cameras[0]: PINHOLE: focal length fx must be > 0"),
    "checkpoint_metadata/not_json.json": (b'{"encoder":', "OmniPoint config is not valid JSON"),
    "checkpoint_metadata/overflow.json": (BUNDLED_CONFIG.replace(b'"encoder_dim":16', b'"encoder_dim":1e999'),
                                          "OmniPoint config is not valid JSON: [json.exception.out_of_range.406] number overflow"),
    "checkpoint_metadata/moge2_overflow.json": (MOGE2_CONFIG.replace(b'"dim_out": 64', b'"dim_out": -1e999'),
                                                "MoGe-2 config is not valid JSON: [json.exception.out_of_range.406] number overflow"),
    "checkpoint_metadata/encoder_dim_huge.json": (changed(BUNDLED, ["conditioning", "encoder_dim"], 1e300),
                                                  "conditioning.encoder_dim: expected an integer in range"),
    "checkpoint_metadata/unknown_key.json": (changed(BUNDLED, ["bogus"], 1), "bogus: unknown key"),
    "checkpoint_metadata/neck_input.json": (changed(BUNDLED, ["neck", "dim_in", 0], 3),
                                            "neck.dim_in[0]: must be encoder.dim_out + 2 (features and uv)"),
    "checkpoint_metadata/points_head.json": (changed(BUNDLED, ["points_head"], BUNDLED["ray_head"]),
                                             "points_head: only with \"output\": \"xyz\""),
    "checkpoint_metadata/dim_fraction.json": (changed(BUNDLED, ["neck", "dim_res_blocks", 1], 24.5),
                                              "neck.dim_res_blocks[1]: expected an integer in range"),
    "checkpoint_metadata/no_mask_head.json": (changed(TINY, ["mask_head"], None), "mask_head: required"),
    "checkpoint_metadata/moge2_no_points_head.json": (changed(MOGE2, ["points_head"], None),
                                                      "MoGe-2 config: points_head: required"),
    "checkpoint_metadata/moge2_layers.json": (changed(MOGE2, ["encoder", "intermediate_layers"], 99),
                                              "encoder.intermediate_layers: expected an integer in range [1, 4], got 99"),
    "checkpoint_metadata/moge2_depth.json": (changed(MOGE2, ["encoder", "backbone_config", "depth"], 1e12),
                                             "encoder.backbone_config.depth: must lie in [1, 1024]"),
    "checkpoint_metadata/moge2_norm.json": (changed(MOGE2, ["neck", "res_block_in_norm"], "group_norm"),
                                            "neck.res_block_in_norm: only \"none\" is supported, got \"group_norm\""),
    "png_text/bad_signature.png": (b"\x89PNX\r\n\x1a\n" + png(NEAR_FAR)[8:], "bad signature"),
    "png_text/crc.png": (png(NEAR_FAR).replace(b"0.5", b"0.6", 1), "CRC mismatch in tEXt"),
    "png_text/truncated.png": (png(NEAR_FAR)[:40], "truncated chunk"),
    "png_text/long_chunk.png": (png(NEAR_FAR)[:8] + struct.pack(">I", 1 << 30) + b"IHDR" + bytes(20),
                                "chunk longer than the file"),
    "png_text/no_near.png": (png(((b"far", b"2"),)), "no 'near' text chunk"),
    "png_text/near_word.png": (png(((b"near", b"close"), (b"far", b"2"))), "text chunk 'near' is not a number: close"),
    "png_text/near_suffix.png": (png(((b"near", b"1m"), (b"far", b"2"))), "text chunk 'near' is not a number: 1m"),
    "png_text/far_below.png": (png(((b"near", b"2"), (b"far", b"1"))), "expected 0 < near < far"),
    "png_text/unit_negative.png": (png(NEAR_FAR + ((b"unit", b"-1"),)), "expected a finite unit > 0"),
    "moge_meta/not_json.json": (b"{intrinsics}", "not valid JSON"),
    "moge_meta/no_intrinsics.json": (js({"K": K}), "needs \"intrinsics\" as a 3x3 array"),
    "moge_meta/strings.json": (js({"intrinsics": [["a", 0, 0.5], [0, 1, 0.5], [0, 0, 1]]}),
                               "needs \"intrinsics\" as a 3x3 array"),
    "moge_meta/zero_focal.json": (js({"intrinsics": [[0, 0, 0.5], [0, 1, 0.5], [0, 0, 1]]}),
                                  "bad intrinsics: PINHOLE: focal length fx must be > 0"),
    "sample_meta/not_json.json": (b"camera: PINHOLE", "meta.json is not valid JSON"),
    "sample_meta/no_camera.json": (js({"metric": True}), "meta.json has no \"camera\""),
    "sample_meta/bad_camera.json": (js({"camera": "NO_SUCH_MODEL 16 12 1 2 3"}),
                                    "unknown or invalid camera: unknown camera model 'NO_SUCH_MODEL'"),
    "sample_meta/metric_number.json": (js({"camera": "PINHOLE 16 12 14 14 8 6", "metric": 1}),
                                       "\"metric\" must be true or false, got 1"),
    "sample_meta/labelled_string.json": (js({"camera": "PINHOLE 16 12 14 14 8 6", "labelled": "no"}),
                                         "meta.json \"labelled\" must be true or false, got \"no\""),
    "sample_meta/array.json": (b"[1, 2]", "meta.json has no \"camera\""),
    "hub_model_info/not_json.json": (b"<html>", "is not a model description"),
    "hub_model_info/no_siblings.json": (js({"id": "o/r"}), "is not a model description"),
    "hub_model_info/number_name.json": (js({"siblings": [{"rfilename": 7}]}), "is not a model description"),
    "hub_model_info/parent.json": (js({"siblings": [{"rfilename": "../../evil.pt"}]}),
                                   "lists the file \"../../evil.pt\", which is no path inside the repository"),
    "hub_model_info/absolute.json": (js({"siblings": [{"rfilename": "/etc/model.pt"}]}),
                                     "which is no path inside the repository"),
    "kitti_text/calib_cam_to_cam_no_p.txt": (KITTI_CAM_TO_CAM.replace(b"P_rect_02", b"P_rect_2"),
                                              "no key P_rect_02"),
    "kitti_text/image_02_model.yaml": (KITTI360_FISHEYE.replace(b"MEI", b"PINHOLE"),
                                       "only MEI (the KITTI-360 fisheyes' model) is read"),
    "kitti_text/poses_short.txt": (b"3 1 0 0 0 0 1 0 0 0 0 1\n", "expected 13 numbers"),
    "kitti_text/eigen_side.txt": (b"2011_09_26/2011_09_26_drive_0002_sync 69 x\n", "the side must be l or r"),
}

def checkpoint_malformed():
    import torch
    good = checkpoint_seeds()["state_dict.pt"]
    legacy = torch_checkpoint({"w": torch.ones(2)}, _use_new_zipfile_serialization=False)
    return {
        "checkpoint/os_system.pkl": (pickle_global("os", "system", "touch pwned"),
                                     "refuses the pickled global 'os.system'"),
        "checkpoint/builtins_eval.pkl": (pickle_global("builtins", "eval", "1+1"),
                                         "refuses the pickled global 'builtins.eval'"),
        "checkpoint/complex.pt": (torch_checkpoint({"w": torch.zeros(2, dtype=torch.complex64)}),
                                  "torch.ComplexFloatStorage is not supported"),
        "checkpoint/legacy.pt": (legacy, "pre-1.6 format"),
        "checkpoint/truncated.pt": (good[:len(good) // 2], "not a readable zip archive"),
        "checkpoint/no_stop.pkl": (data_pkl(good)[:-1], "ends without a STOP opcode"),
        "checkpoint/list.pkl": (b"\x80\x02](K\x01K\x02e.", "holds a list, not a dict of weights"),
        "checkpoint/deep.pkl": (b"\x80\x02" + b"]" * 80 + b"a" * 79 + b".", "nest deeper than 64"),
        "checkpoint/past_storage.pkl": (b"\x80\x02}(X\x01\x00\x00\x00wctorch._utils\n_rebuild_tensor_v2\n((X\x07\x00\x00\x00storage"
                                        b"ctorch\nFloatStorage\nX\x01\x00\x00\x000X\x03\x00\x00\x00cpuK\x04tQK\x02K\x03\x85K\x01\x85"
                                        b"\x89}tRu.", "reaches past the end of its storage"),
    }


MALFORMED.update(checkpoint_malformed())


def write(folder, files):
    shutil.rmtree(os.path.join(HERE, folder), ignore_errors=True)
    for name, content in files.items():
        path = os.path.join(HERE, folder, name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as f:
            f.write(content)


SEEDS.update({"checkpoint/" + name: data for name, data in checkpoint_seeds().items()})
write("corpus", SEEDS)
write("malformed", {name: content for name, (content, _) in MALFORMED.items()})
with open(os.path.join(HERE, "malformed", "expected_errors.txt"), "w") as f:
    f.write("# file<TAB>fragment of the error message (written by make_corpus.py)\n")
    for name, (_, fragment) in sorted(MALFORMED.items()):
        f.write(f"{name}\t{fragment}\n")
