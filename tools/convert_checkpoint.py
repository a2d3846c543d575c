#!/usr/bin/python3
"""Converts a PyTorch pickle checkpoint to OmniPoint's .safetensors weights (needs only PyTorch).

Layouts:
  MoGe-2   {'model_config': {...}, 'model': state_dict}
           -> metadata {"format": "moge2", "config": json.dumps(model_config)}
  bare     state_dict, e.g. DINOv2's hub weights
           -> metadata {"format": "state_dict"}

The file is written by hand in the layout of the Python `safetensors` package (8-byte
little-endian header length, compact JSON header with "__metadata__" first, data ordered by
dtype alignment then by name, header padded with spaces to a multiple of 8), the same bytes
omnipoint::io::encode_safetensors writes.

Example (DINOv2 backbone stored under the names MoGe-2 gives it):
  /usr/bin/python3 tools/convert_checkpoint.py dinov2_vitl14_pretrain.pth dinov2.safetensors \
      --add-prefix encoder.backbone.
"""
import argparse
import json
import os
import struct
import sys
import tempfile

import torch

# safetensors dtype names, in increasing alignment (the reference writer's order).
DTYPES = [
    (torch.bool, "BOOL"), (torch.uint8, "U8"), (torch.int8, "I8"), (torch.int16, "I16"),
    (torch.float16, "F16"), (torch.bfloat16, "BF16"), (torch.int32, "I32"),
    (torch.float32, "F32"), (torch.float64, "F64"), (torch.int64, "I64"),
]
DTYPE_NAME = {dtype: name for dtype, name in DTYPES}
ALIGNMENT_RANK = {dtype: rank for rank, (dtype, _) in enumerate(DTYPES)}
STORE_AS = {"f32": torch.float32, "f16": torch.float16, "bf16": torch.bfloat16}


def split_checkpoint(checkpoint):
    """Returns (state_dict, metadata) for the layouts above; raises ValueError otherwise."""
    if not isinstance(checkpoint, dict):
        raise ValueError(f"expected a dict, got {type(checkpoint).__name__}")
    if "model" in checkpoint and isinstance(checkpoint["model"], dict):
        config = checkpoint.get("model_config")
        if not isinstance(config, dict):
            raise ValueError("has 'model' but no 'model_config' dict (expected MoGe-2's layout)")
        return checkpoint["model"], {"format": "moge2", "config": json.dumps(config)}
    if checkpoint and all(isinstance(v, torch.Tensor) for v in checkpoint.values()):
        return checkpoint, {"format": "state_dict"}
    raise ValueError("neither MoGe-2's {'model_config', 'model'} layout nor a bare state_dict "
                     f"(top-level keys: {sorted(map(str, checkpoint))[:10]})")


def rename(state_dict, add_prefix, strip_prefix):
    out = {}
    for name, tensor in state_dict.items():
        if not isinstance(tensor, torch.Tensor):
            raise ValueError(f"entry '{name}' is a {type(tensor).__name__}, not a tensor")
        if strip_prefix:
            if not name.startswith(strip_prefix):
                raise ValueError(f"key '{name}' lacks the prefix '{strip_prefix}' to strip")
            name = name[len(strip_prefix):]
        out[add_prefix + name] = tensor
    return out


def encode(tensors, metadata, store_as=None):
    """safetensors bytes for a {name: tensor} dict and a {str: str} metadata dict."""
    prepared = []
    for name, tensor in tensors.items():
        tensor = tensor.detach().cpu()
        if store_as is not None and tensor.is_floating_point():
            tensor = tensor.to(store_as)
        if tensor.dtype not in DTYPE_NAME:
            raise ValueError(f"tensor '{name}' has unsupported dtype {tensor.dtype}")
        prepared.append((name, tensor.contiguous()))
    prepared.sort(key=lambda item: (-ALIGNMENT_RANK[item[1].dtype], item[0].encode("utf-8")))

    header, chunks, offset = {}, [], 0
    if metadata:
        header["__metadata__"] = dict(sorted(metadata.items()))
    for name, tensor in prepared:
        data = tensor.reshape(-1).view(torch.uint8).numpy().tobytes()
        header[name] = {"dtype": DTYPE_NAME[tensor.dtype], "shape": list(tensor.shape),
                        "data_offsets": [offset, offset + len(data)]}
        chunks.append(data)
        offset += len(data)
    text = json.dumps(header, separators=(",", ":"), ensure_ascii=False).encode("utf-8")
    text += b" " * (-len(text) % 8)
    return struct.pack("<Q", len(text)) + text + b"".join(chunks)


def write_atomically(path, data):
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix="." + os.path.basename(path) + ".tmp-")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("input", help="PyTorch checkpoint (.pt/.pth, pickle)")
    parser.add_argument("output", help="output .safetensors file")
    parser.add_argument("--add-prefix", default="", help="prepend this to every key")
    parser.add_argument("--strip-prefix", default="",
                        help="remove this prefix from every key (each key must have it)")
    parser.add_argument("--dtype", choices=sorted(STORE_AS),
                        help="store floating-point tensors in this dtype (default: as stored)")
    parser.add_argument("--unsafe-full-pickle", action="store_true",
                        help="allow arbitrary pickled objects (runs code from the file; only for "
                             "trusted checkpoints that torch.load(weights_only=True) rejects)")
    args = parser.parse_args(argv)

    try:
        checkpoint = torch.load(args.input, map_location="cpu",
                                weights_only=not args.unsafe_full_pickle)
        state_dict, metadata = split_checkpoint(checkpoint)
        tensors = rename(state_dict, args.add_prefix, args.strip_prefix)
        data = encode(tensors, metadata, STORE_AS.get(args.dtype))
        write_atomically(args.output, data)
    except Exception as e:  # one clear line, as the C++ tools do
        print(f"convert_checkpoint: error: {args.input}: {e}", file=sys.stderr)
        return 1
    print(f"{args.output}: {len(tensors)} tensors, format {metadata['format']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
