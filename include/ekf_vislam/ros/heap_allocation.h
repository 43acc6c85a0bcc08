// The estimator's update allocates dense matrices of a few MB per frame (state dimension x
// observation rows). glibc serves allocations that large with mmap and returns them to the system
// when freed, so every frame pays page faults on fresh memory (about half of vislam_offline's
// time with the reported covariance). Raising the mmap and trim thresholds keeps them on the heap
// and reuses them: the usual setting for a real-time process. It applies to the whole process
// (node, nodelet manager or offline runner) and costs at most the peak of those buffers in
// resident memory.
#pragma once

#include <malloc.h>

namespace ekf_vislam {

inline void keepLargeAllocationsOnHeap() {
#ifdef M_MMAP_THRESHOLD
  constexpr int kThresholdBytes = 256 << 20;
  mallopt(M_MMAP_THRESHOLD, kThresholdBytes);
  mallopt(M_TRIM_THRESHOLD, 2 * kThresholdBytes);
#endif
}

}  // namespace ekf_vislam
