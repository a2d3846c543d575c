#!/usr/bin/python3
"""Times MoGe's own Python forward and OmniPoint's C++ forward in one run, interleaved.

Both sides build MoGe-2 with the configuration of bench/bench_forward.cpp (the published ViT-L
decoder: neck/head dims [C,256,128,64,32], neck residual blocks [0,2,2,2,0], heads
[0,1,1,1,0], points + mask + normal heads, scale MLP [C,C,C,1], remap "exp", intermediate
layers [5,11,17,23] for ViT-L, [2,5,8,11] for ViT-S/B), random weights, eval mode, inference
mode, 2 intra-op threads, a random 480x640 image. What is timed is the network forward:
MoGe's `MoGeModel.forward(image, num_tokens)` (moge/model/v2.py) and `MoGe2Model::forward`
(the `BM_Forward` benchmark); both include the image resize to the token grid, the heads'
resize to the image size and the output remap, neither includes `infer()`'s post-processing.
Each measurement is a fresh process (model construction, one untimed warm-up forward, one
timed forward), run in rounds of [ours fp32, theirs fp32, ours bf16, theirs bf16] so that a
change of the machine's load affects both sides alike. Python bf16 is
`torch.autocast("cpu", dtype=torch.bfloat16)`; ours is bench_forward's `bf16:1`.

The MoGe checkout is the user's (not vendored). It is run with Debian's python3-torch 1.13,
for which this script installs small run-time shims before importing it:
  - `torch.nn.functional.scaled_dot_product_attention` (PyTorch 2.x; MoGe's DINOv2 attention
    calls it) as softmax((q / sqrt(d)) kᵀ) v, the scale folded into q as in DINOv2's original
    attention;
  - empty stand-ins for the modules that only `infer()`'s post-processing or checkpoint
    download use (utils3d, huggingface_hub, cv2, scipy), where they are not installed; a
    stand-in raises if anything from it is called. Put a real utils3d on PYTHONPATH to use it.

Usage (from the repository root, after building bench_forward):
  /usr/bin/python3 bench/moge_side_by_side.py --moge /path/to/MoGe \
      [--bench build/bench/bench_forward] [--vit L] [--vit S] [--rounds 3] [--tokens 1200]
Prints every measurement as it comes, the `uptime` before and after, then per-configuration
medians and the ratios theirs / ours (wall time; CPU seconds of all threads next to them; the
wall-time ratio of each round).
"""
import argparse
import importlib.util
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import types

IMAGE_HEIGHT, IMAGE_WIDTH = 480, 640
THREADS = 2

# bench_forward's backbone index and MoGe's hub name per ViT size.
VITS = {"S": (0, "dinov2_vits14", 384, [2, 5, 8, 11]),
        "B": (1, "dinov2_vitb14", 768, [2, 5, 8, 11]),
        "L": (2, "dinov2_vitl14", 1024, [5, 11, 17, 23])}

# Packages MoGe imports at load time but uses only outside `forward`, with the submodules it
# imports from them.
FORWARD_UNUSED_PACKAGES = {"utils3d": [], "huggingface_hub": [], "cv2": [], "scipy": ["signal"]}


def conv_stack(width, neck, dim_out):
    return {"dim_in": [width + 2, 2, 2, 2, 2] if neck else [width, 256, 128, 64, 32],
            "dim_out": dim_out,
            "dim_res_blocks": [width, 256, 128, 64, 32],
            "num_res_blocks": [0, 2, 2, 2, 0] if neck else [0, 1, 1, 1, 0],
            "res_block_in_norm": "none",
            "res_block_hidden_norm": "none",
            "resamplers": ["conv_transpose", "conv_transpose", "conv_transpose", "bilinear"]}


def moge2_config(vit):
    """The keyword arguments of MoGe's v2 MoGeModel equal to bench_forward's moge2_config."""
    _, backbone, width, layers = VITS[vit]
    return {"encoder": {"backbone": backbone, "intermediate_layers": layers, "dim_out": width},
            "neck": conv_stack(width, True, None),
            "points_head": conv_stack(width, False, [None, None, None, None, 3]),
            "mask_head": conv_stack(width, False, [None, None, None, None, 1]),
            "normal_head": conv_stack(width, False, [None, None, None, None, 3]),
            "scale_head": {"dims": [width, width, width, 1]},
            "remap_output": "exp",
            "num_tokens_range": [1200, 3600]}


def cpu_seconds():
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


class ForwardUnusedModule(types.ModuleType):
    """Stands in for a module MoGe imports but whose contents `forward` never calls."""

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)

        def unavailable(*args, **kwargs):
            raise RuntimeError(f"{self.__name__}.{name} is not available in this benchmark "
                               "(only MoGe's forward is run)")
        return unavailable


def install_torch113_shims(torch):
    for package, submodules in FORWARD_UNUSED_PACKAGES.items():
        if importlib.util.find_spec(package) is None:
            for name in [package] + [f"{package}.{submodule}" for submodule in submodules]:
                sys.modules[name] = ForwardUnusedModule(name)
    functional = torch.nn.functional
    if not hasattr(functional, "scaled_dot_product_attention"):
        def scaled_dot_product_attention(q, k, v, attn_mask=None):
            if attn_mask is not None:
                raise NotImplementedError("attention masks are not shimmed")
            q = q * q.shape[-1] ** -0.5
            return torch.softmax(q @ k.transpose(-2, -1), dim=-1) @ v
        functional.scaled_dot_product_attention = scaled_dot_product_attention


def python_worker(moge_dir, vit, bf16, tokens):
    """One measurement of MoGe's Python forward; prints {"wall_s", "cpu_s"} as JSON."""
    import torch
    install_torch113_shims(torch)
    sys.path.insert(0, moge_dir)
    from moge.model.v2 import MoGeModel

    torch.set_num_threads(THREADS)
    torch.manual_seed(0)
    model = MoGeModel(**moge2_config(vit)).eval()
    image = torch.rand(1, 3, IMAGE_HEIGHT, IMAGE_WIDTH)
    with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
        model.forward(image, num_tokens=tokens)  # warm-up
        cpu_start, wall_start = cpu_seconds(), time.perf_counter()
        model.forward(image, num_tokens=tokens)
        wall, cpu = time.perf_counter() - wall_start, cpu_seconds() - cpu_start
    print(json.dumps({"wall_s": wall, "cpu_s": cpu}))


def run_theirs(moge_dir, vit, bf16, tokens):
    command = [sys.executable, os.path.abspath(__file__), "--moge", moge_dir, "--worker",
               "--vit", vit, "--tokens", str(tokens)] + (["--bf16"] if bf16 else [])
    result = subprocess.run(command, check=True, capture_output=True, text=True)
    return json.loads(result.stdout.strip().splitlines()[-1])


def run_ours(bench, vit, bf16, tokens):
    name = f"BM_Forward/vit:{VITS[vit][0]}/tokens:{tokens}/bf16:{int(bf16)}/"
    with tempfile.NamedTemporaryFile(suffix=".json") as out:
        subprocess.run([bench, f"--benchmark_filter=^{name}", f"--benchmark_out={out.name}",
                        "--benchmark_out_format=json"],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        runs = json.load(open(out.name))["benchmarks"]
    if len(runs) != 1 or runs[0]["time_unit"] != "ms":
        raise RuntimeError(f"{bench}: expected one {name} result in ms, got {runs}")
    return {"wall_s": runs[0]["real_time"] / 1000, "cpu_s": runs[0]["cpu_s"]}


def uptime():
    return subprocess.run(["uptime"], check=True, capture_output=True, text=True).stdout.strip()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--moge", required=True, help="a MoGe source checkout (holds moge/)")
    parser.add_argument("--bench", default="build/bench/bench_forward",
                        help="OmniPoint's bench_forward binary")
    parser.add_argument("--vit", action="append", choices=sorted(VITS),
                        help="ViT size, repeatable (default: L)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--tokens", type=int, default=1200)
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--bf16", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    moge_dir = os.path.abspath(args.moge)
    if not os.path.isfile(os.path.join(moge_dir, "moge", "model", "v2.py")):
        parser.error(f"{moge_dir}: not a MoGe checkout (no moge/model/v2.py)")
    vits = args.vit or ["L"]
    if args.worker:
        python_worker(moge_dir, vits[0], args.bf16, args.tokens)
        return
    if not os.access(args.bench, os.X_OK):
        parser.error(f"{args.bench}: no bench_forward binary (build the bench_forward target)")

    order = [("ours", False), ("theirs", False), ("ours", True), ("theirs", True)]
    times = {}
    print(f"uptime before: {uptime()}", flush=True)
    for round_index in range(args.rounds):
        for vit in vits:
            for side, bf16 in order:
                result = (run_ours(args.bench, vit, bf16, args.tokens) if side == "ours"
                          else run_theirs(moge_dir, vit, bf16, args.tokens))
                times.setdefault((vit, side, bf16), []).append(result)
                load = os.getloadavg()[0]
                print(f"round {round_index + 1} ViT-{vit} {side:6} {'bf16' if bf16 else 'fp32'}: "
                      f"{result['wall_s']:7.2f} s wall, {result['cpu_s']:7.2f} CPU s "
                      f"(load {load:.1f})", flush=True)
    print(f"uptime after: {uptime()}")

    def median(vit, side, bf16, key):
        return statistics.median(r[key] for r in times[(vit, side, bf16)])

    print(f"\nMedians of {args.rounds} rounds, {args.tokens} tokens, "
          f"{IMAGE_HEIGHT}x{IMAGE_WIDTH}, {THREADS} threads:")
    for vit in vits:
        for side, bf16 in order:
            print(f"  ViT-{vit} {side:6} {'bf16' if bf16 else 'fp32'}: "
                  f"{median(vit, side, bf16, 'wall_s'):7.2f} s wall, "
                  f"{median(vit, side, bf16, 'cpu_s'):7.2f} CPU s")
        print(f"  ViT-{vit} ratios theirs / ours (wall; CPU s):")
        for label, theirs_bf16, ours_bf16 in [("fp32 / fp32", False, False),
                                              ("their fp32 / our bf16", False, True),
                                              ("bf16 / bf16", True, True)]:
            ratios = [median(vit, "theirs", theirs_bf16, key) / median(vit, "ours", ours_bf16, key)
                      for key in ("wall_s", "cpu_s")]
            # Within a round both ran minutes apart, so these pairs see the most similar load.
            per_round = [theirs["wall_s"] / ours["wall_s"] for theirs, ours in
                         zip(times[(vit, "theirs", theirs_bf16)], times[(vit, "ours", ours_bf16)])]
            print(f"    {label:22}: {ratios[0]:.2f}x; {ratios[1]:.2f}x "
                  f"(wall per round: {', '.join(f'{ratio:.2f}' for ratio in per_round)})")


if __name__ == "__main__":
    main()
