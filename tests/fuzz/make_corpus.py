"""Regenerates the fuzzing seed corpus (corpus/) and the hand-made malformed files
(malformed/, with expected_errors.txt) replayed by tests/io/test_parser_corpus.cpp.
Run with Debian's Python: /usr/bin/python3 tests/fuzz/make_corpus.py"""
import io
import json
import os
import shutil
import struct

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
}


def write(folder, files):
    shutil.rmtree(os.path.join(HERE, folder), ignore_errors=True)
    for name, content in files.items():
        path = os.path.join(HERE, folder, name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as f:
            f.write(content)


write("corpus", SEEDS)
write("malformed", {name: content for name, (content, _) in MALFORMED.items()})
with open(os.path.join(HERE, "malformed", "expected_errors.txt"), "w") as f:
    f.write("# file<TAB>fragment of the error message (written by make_corpus.py)\n")
    for name, (_, fragment) in sorted(MALFORMED.items()):
        f.write(f"{name}\t{fragment}\n")
