#pragma once
// How this process's heap treats freed memory; every program of the project calls this first.

namespace omnipoint::io {

// Freed memory stays in the heap for the next allocation. LibTorch allocates and frees
// tensors of a few hundred kB to hundreds of MB in every op (a ViT-L attention's scores are
// 92 MB at 1,200 tokens); glibc maps each large one afresh from the kernel by default, and the
// page faults of that cost as much time as the work itself in places (docs/PERFORMANCE.md).
void keep_freed_memory_in_heap();

}  // namespace omnipoint::io
