#include "omnipoint/io/process_memory.h"

#include <malloc.h>

namespace omnipoint::io {

void keep_freed_memory_in_heap() {
  // Blocks below 256 MB come from the heap, and the heap keeps up to 1 GB of freed memory.
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
}

}  // namespace omnipoint::io
