"""Writes tiny PyTorch checkpoints for test_convert_checkpoint.cpp, with each tensor's values
as float32/int64/bool .npy files (the expected content) beside them, then runs each JOB
("INPUT OUTPUT [OPTIONS]", paths in DIR) through tools/convert_checkpoint.py in this one
process (PyTorch takes seconds to import) and writes the exit statuses to DIR/status.txt.
Usage: make_checkpoints.py DIR [JOB...]"""
import json
import os
import shlex
import sys

try:
    import numpy as np
    import torch
except ImportError:
    sys.exit(77)  # the C++ test skips

out = sys.argv[1]
torch.manual_seed(0)
tensors = {
    "blocks.0.attn.qkv.weight": torch.randn(6, 2),
    "blocks.0.ls1.gamma": torch.randn(2) * 1e-3,
    "norm.bias": torch.randn(2).to(torch.float64),
    "patch_embed.proj.weight": torch.randn(2, 3, 2, 2).to(torch.float16),
    "pos_embed": torch.randn(1, 5, 2).to(torch.bfloat16),
    "steps": torch.tensor([7, -3], dtype=torch.int64),
    "valid": torch.tensor([True, False, True]),
    "scalar": torch.tensor(2.5),
}
tensors["transposed"] = torch.randn(3, 4).t()  # non-contiguous
for name, t in tensors.items():
    array = t.float() if t.dtype in (torch.float16, torch.bfloat16) else t  # exact widening
    np.save(os.path.join(out, name + ".npy"), array.contiguous().numpy())

config = {"encoder": {"backbone": "dinov2_custom", "dim_out": 2, "intermediate_layers": [0]},
          "remap_output": "exp", "name": "tïny \"model\""}
torch.save({"model_config": config, "model": tensors}, os.path.join(out, "moge2.pt"))
with open(os.path.join(out, "config.txt"), "w", encoding="utf-8") as f:
    f.write(json.dumps(config))
torch.save({"module." + k: v for k, v in tensors.items()}, os.path.join(out, "bare.pt"))
torch.save([1, 2, 3], os.path.join(out, "list.pt"))

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))
import convert_checkpoint  # noqa: E402

statuses = []
for job in sys.argv[2:]:
    source, target, *options = shlex.split(job)
    statuses.append(convert_checkpoint.main([os.path.join(out, source), os.path.join(out, target)] + options))
with open(os.path.join(out, "status.txt"), "w") as f:
    f.write("\n".join(map(str, statuses)) + "\n")
