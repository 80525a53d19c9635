// The neighbour lists' loops over rows, shared by neighbor_list.cpp and near_list.cpp: each row
// written by one thread, so the lists are the same for any thread count.
#pragma once
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "tsubu/neighbor_list.hpp"

namespace tsubu::list_loops {

// Inside a parallel region: this thread's number and the team's size.
struct Part {
  int t, nt;
};
inline Part part() {
#ifdef _OPENMP
  return {omp_get_thread_num(), omp_get_num_threads()};
#else
  return {0, 1};
#endif
}

// Which per-sphere values every sphere held shares, bit for bit, with sphere 0: its radius
// (`radius`), and its radius, mass, inverse mass and material together (`body`; a fixed sphere's
// inverse mass is 0). One pass over the four arrays in the threads' parts, each part stopping at
// its first other radius (a polydisperse scene reads a few values); serial work before, five
// passes, was 1 ms a refresh at N = 1e6 that no thread shared.
struct Alike {
  bool radius, body;
};
inline Alike alike_spheres(const ParticleStore& ps, int threads) {
  const long n = static_cast<long>(ps.radius.size());
  if (n == 0) return {false, false};
  auto bits = [](double d) {
    std::uint64_t u;
    std::memcpy(&u, &d, sizeof u);
    return u;
  };
  const double *const radius = ps.radius.data(), *const mass = ps.mass.data(),
                      *const inv_mass = ps.inv_mass.data();
  const int* const material = ps.material.data();
  const std::uint64_t r0 = bits(radius[0]), m0 = bits(mass[0]), i0 = bits(inv_mass[0]);
  const int k0 = material[0];
  constexpr long kRun = 4096;  // values between two looks at the radius found so far
  int other_radius = 0, other_body = 0;
#pragma omp parallel num_threads(threads) if (threads > 1 && n > kRun) reduction(| : other_radius, other_body)
  {
    const Part me = part();
    const long lo = n * me.t / me.nt, hi = n * (me.t + 1) / me.nt;
    for (long a = lo; a < hi && !other_radius; a += kRun) {
      const long b = std::min(hi, a + kRun);
      int r = 0, o = 0;
      for (long k = a; k < b; ++k) {
        r |= bits(radius[k]) != r0;
        o |= (bits(mass[k]) != m0) | (bits(inv_mass[k]) != i0) | (material[k] != k0);
      }
      other_radius |= r;
      other_body |= o;
    }
  }
  return {other_radius == 0, other_radius == 0 && other_body == 0};
}

// The k in [0, n) that pass `keep`, in order, into `out`: counted in parts, then written.
template <class Keep>
inline void filter(long n, Keep&& keep, Array<Index>& out, const NeighborList::Context& c) {
  const int most = c.parallel ? std::max(1, c.threads) : 1;
  if (most == 1) {  // counted, then written without a branch into count + 1 places (not n:
                    // a list of a few spheres of a million keeps no 4 MB)
    Index count = 0;
    for (long k = 0; k < n; ++k) count += keep(k) ? 1 : 0;
    const std::size_t room = static_cast<std::size_t>(count) + 1;
    if (room > out.capacity()) out.reserve(room + room / 8);
    out.resize(room);
    Index at = 0;
    for (long k = 0; k < n; ++k) {
      out[at] = static_cast<Index>(k);
      at += keep(k) ? 1 : 0;
    }
    out.resize(static_cast<std::size_t>(count));
    return;
  }
  std::vector<Index> start(static_cast<std::size_t>(most) + 1, 0);
#pragma omp parallel num_threads(most) if (most > 1)
  {
    const auto [t, nt] = part();
    const long lo = n * t / nt, hi = n * (t + 1) / nt;
    Index count = 0;
    for (long k = lo; k < hi; ++k) count += keep(k) ? 1 : 0;
    start[t + 1] = count;
#pragma omp barrier
#pragma omp single
    {
      for (int u = 0; u < nt; ++u) start[u + 1] += start[u];
      out.resize(static_cast<std::size_t>(start[nt]));
    }
    Index at = start[t];
    for (long k = lo; k < hi; ++k)
      if (keep(k)) out[at++] = static_cast<Index>(k);
  }
}

// Row offsets from row counts: a[k + 1] += a[k] for k in [0, n), a[0] given. From kScanRows rows
// on, in parts on up to `threads` threads (each part summed, the parts' sums run through, then
// each part written): integer sums, the same for any split.
constexpr long kScanRows = 1L << 16;
inline void running_sums(Index* a, long n, int threads) {
  if (threads <= 1 || n < kScanRows) {
    for (long k = 0; k < n; ++k) a[k + 1] += a[k];
    return;
  }
  std::vector<Index> before(static_cast<std::size_t>(threads) + 1, 0);
#pragma omp parallel num_threads(threads)
  {
    const auto [t, nt] = part();
    const long lo = n * t / nt, hi = n * (t + 1) / nt;
    Index sum = 0;
    for (long k = lo; k < hi; ++k) sum += a[k + 1];
    before[t + 1] = sum;
#pragma omp barrier
#pragma omp single
    {
      before[0] = a[0];
      for (int u = 0; u < nt; ++u) before[u + 1] += before[u];
    }
    Index run = before[t];
    for (long k = lo; k < hi; ++k) a[k + 1] = (run += a[k + 1]);
  }
}
inline int scan_threads(const NeighborList::Context& c) { return c.parallel ? c.threads : 1; }

// a[k] = 0 for every k, the rows shared between the threads.
inline void zero(Array<double>& a, const NeighborList::Context& c) {
  const long size = static_cast<long>(a.size());
  double* p = a.data();
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
  for (long k = 0; k < size; ++k) p[k] = 0.0;
}

// to[w q + k] = from[w src[q] + k] for q in [0, n), k in [0, w): rows of w values gathered, on
// `threads` threads where > 1. The contact state's widths (1, 3, 4) are unrolled: a loop of
// unknown length per row costs more than the copy.
template <int W>
inline void gather_rows(double* __restrict to, const double* __restrict from, const Index* src, long n,
                        int w, int threads) {
  const long width = W > 0 ? W : w;
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
  for (long q = 0; q < n; ++q) {
    const double* f = from + width * src[q];
    for (long k = 0; k < width; ++k) to[width * q + k] = f[k];
  }
}
inline void gather_rows(double* to, const double* from, const Index* src, long n, int w, int threads) {
  switch (w) {
    case 1: return gather_rows<1>(to, from, src, n, w, threads);
    case 3: return gather_rows<3>(to, from, src, n, w, threads);
    case 4: return gather_rows<4>(to, from, src, n, w, threads);
    default: return gather_rows<0>(to, from, src, n, w, threads);
  }
}

// The entries' touch flags from their overlaps.
inline void mark_touching(EntryStore& st, const NeighborList::Context& c) {
  const long size = static_cast<long>(st.overlap.size());
  const double* o = st.overlap.data();
  std::uint8_t* t = st.touch.data();
#pragma omp parallel for schedule(static) num_threads(c.threads) if (c.parallel)
  for (long q = 0; q < size; ++q) t[q] = touching(c.law, o[q]);
}

template <class Key>
inline void insertion_sort(Index* first, Index* last, Key key) {
  for (Index* a = first + 1; a < last; ++a) {
    const Index v = *a;
    const auto kv = key(v);
    Index* b = a;
    for (; b > first && key(*(b - 1)) > kv; --b) *b = *(b - 1);
    *b = v;
  }
}

}  // namespace tsubu::list_loops
