"""Writes PyTorch checkpoints with torch.save for test_torch_checkpoint_python.cpp, with what
the C++ reader must find in them:
  moge2.pt, moge2_p4.pt  MoGe-2's layout {'model_config', 'model': state_dict()} of the
                         MoGe-2 fixture (SOURCE, a .safetensors), protocols 2 and 4;
                         moge2_converted.safetensors, moge2.pt through tools/convert_checkpoint.py;
                         moge2_bad_keys.pt with a key missing, one unexpected, one mis-shaped
                         (their names in bad_keys.txt)
  tensors.pt             an OrderedDict of every supported dtype, a transposed tensor, a slice
                         with a storage offset, two views of one storage, nn.Parameters, a scalar
                         and an empty tensor; tensors.safetensors the same, contiguous
  dinov2.pth             a bare DINOv2 state dict (plain dict), from SOURCE's backbone tensors
  os_system.pt, eval.pt  objects whose unpickling would run os.system / builtins.eval
  complex.pt             a complex64 tensor; legacy.pt the pre-1.6 format; list.pt a list
Usage: make_torch_checkpoints.py DIR SOURCE. Exit 77 without torch (the C++ test skips)."""
import collections
import json
import os
import struct
import sys

try:
    import torch
except ImportError:
    sys.exit(77)

out, source = sys.argv[1], sys.argv[2]
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))
import convert_checkpoint  # noqa: E402

SAFETENSORS_DTYPES = {"F32": torch.float32, "F16": torch.float16, "BF16": torch.bfloat16,
                      "F64": torch.float64, "I64": torch.int64, "I32": torch.int32,
                      "I16": torch.int16, "I8": torch.int8, "U8": torch.uint8, "BOOL": torch.bool}


def read_safetensors(path):
    with open(path, "rb") as f:
        data = f.read()
    (length,) = struct.unpack("<Q", data[:8])
    header = json.loads(data[8:8 + length])
    metadata = header.pop("__metadata__", {})
    tensors = collections.OrderedDict()
    for name, info in sorted(header.items()):
        begin, end = info["data_offsets"]
        raw = bytearray(data[8 + length + begin:8 + length + end])
        tensor = torch.frombuffer(raw, dtype=SAFETENSORS_DTYPES[info["dtype"]]) if raw else \
            torch.empty(0, dtype=SAFETENSORS_DTYPES[info["dtype"]])
        tensors[name] = tensor.reshape(info["shape"]).clone()
    return tensors, metadata


def path(name):
    return os.path.join(out, name)


# MoGe-2's published layout: the module's state_dict() (an OrderedDict with _metadata).
tensors, metadata = read_safetensors(source)
state = collections.OrderedDict(tensors)
state._metadata = collections.OrderedDict([("", {"version": 1})])
checkpoint = {"model_config": json.loads(metadata["config"]), "model": state}
torch.save(checkpoint, path("moge2.pt"))
torch.save(checkpoint, path("moge2_p4.pt"), pickle_protocol=4)
# (--unsafe-full-pickle: torch 1.13's weights_only unpickler lacks BINFLOAT, which MoGe's
# config needs; this file is our own.)
assert convert_checkpoint.main([path("moge2.pt"), path("moge2_converted.safetensors"),
                                "--unsafe-full-pickle"]) == 0
# The same with one tensor missing, one unexpected and one of another shape.
names = list(state)
bad = collections.OrderedDict(state)
del bad[names[0]]
bad["extra.weight"] = torch.zeros(1)
bad[names[1]] = torch.zeros(3, 3, 3)
torch.save({"model_config": checkpoint["model_config"], "model": bad}, path("moge2_bad_keys.pt"))
with open(path("bad_keys.txt"), "w") as f:
    f.write(names[0] + "\n" + names[1] + "\n")

# Every dtype, strides, offsets, shared storage, parameters.
torch.manual_seed(0)
base = torch.randn(6, 5)
values = collections.OrderedDict()
for dtype in [torch.float32, torch.float16, torch.bfloat16, torch.float64]:
    values[str(dtype)] = (torch.randn(3, 4) * 10).to(dtype)
for dtype in [torch.int64, torch.int32, torch.int16, torch.int8, torch.uint8]:
    values[str(dtype)] = torch.arange(12).reshape(3, 4).to(dtype) * (1 if dtype == torch.uint8 else -3)
values["torch.bool"] = torch.rand(3, 4) > 0.5
values["transposed"] = base.t()
values["offset_slice"] = base[2:4, 1:4]
values["shared_a"] = base[0]
values["shared_b"] = base[1:3]
values["parameter"] = torch.nn.Parameter(torch.randn(2, 2))
values["scalar"] = torch.tensor(-1.25)
values["empty"] = torch.zeros(0, 3)
torch.save(values, path("tensors.pt"))
with open(path("tensors.safetensors"), "wb") as f:
    f.write(convert_checkpoint.encode({k: v.detach() for k, v in values.items()}, {}))

# DINOv2 hub weights: bare names, a plain dict.
prefix = "encoder.backbone."
torch.save({k[len(prefix):]: v for k, v in tensors.items() if k.startswith(prefix)}, path("dinov2.pth"))


class Runs:
    def __init__(self, function, argument):
        self.function, self.argument = function, argument

    def __reduce__(self):
        return (self.function, (self.argument,))


torch.save({"w": Runs(os.system, "touch " + path("pwned"))}, path("os_system.pt"))
torch.save({"w": Runs(eval, "open(%r, 'w')" % path("pwned"))}, path("eval.pt"))
torch.save({"w": torch.zeros(2, dtype=torch.complex64)}, path("complex.pt"))
torch.save({"w": torch.ones(2)}, path("legacy.pt"), _use_new_zipfile_serialization=False)
torch.save([torch.ones(2)], path("list.pt"))
