#!/usr/bin/python3
"""Copies a .safetensors file with every F32/F64 tensor stored as F16 (other dtypes and the
__metadata__, e.g. an OmniPoint model's config, unchanged). The bundled model is shipped so:

    tools/safetensors_to_f16.py runs/default_model/model_ema.safetensors \
        models/omnipoint_default.safetensors

Loading converts back to the module's dtype (omnipoint/model/state_dict.h). Fails with one
line naming the problem for a file that is not safetensors or a value F16 cannot hold.
"""
import json
import os
import struct
import sys
import tempfile

import numpy as np

FLOATS = {"F32": np.float32, "F64": np.float64}


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: safetensors_to_f16.py IN.safetensors OUT.safetensors")
    source, target = sys.argv[1], sys.argv[2]
    with open(source, "rb") as f:
        raw = f.read()
    try:
        (length,) = struct.unpack("<Q", raw[:8])
        header = json.loads(raw[8:8 + length])
    except (struct.error, ValueError) as error:
        sys.exit(f"safetensors_to_f16: {source}: not a safetensors file ({error})")
    data = raw[8 + length:]
    out_header, chunks, offset = {}, [], 0
    for name, info in header.items():
        if name == "__metadata__":
            out_header[name] = info
            continue
        begin, end = info["data_offsets"]
        block = data[begin:end]
        dtype = info["dtype"]
        if dtype in FLOATS:
            values = np.frombuffer(block, dtype=FLOATS[dtype])
            if np.any(np.abs(values[np.isfinite(values)]) > np.finfo(np.float16).max):
                sys.exit(f"safetensors_to_f16: {source}: tensor {name} has values beyond the F16 range")
            block, dtype = values.astype(np.float16).tobytes(), "F16"
        out_header[name] = {"dtype": dtype, "shape": info["shape"], "data_offsets": [offset, offset + len(block)]}
        chunks.append(block)
        offset += len(block)
    text = json.dumps(out_header, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 8)  # keep the data 8-byte aligned
    folder = os.path.dirname(os.path.abspath(target))
    with tempfile.NamedTemporaryFile(dir=folder, delete=False) as f:  # written whole, then renamed
        f.write(struct.pack("<Q", len(text)) + text + b"".join(chunks))
    os.chmod(f.name, 0o644)
    os.replace(f.name, target)


if __name__ == "__main__":
    main()
