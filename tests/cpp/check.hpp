// A minimal test harness: CHECK(...) records failures with file, line and expression, and a
// test program exits non-zero if any failed. No framework to install.
#pragma once
#include <cmath>
#include <cstdio>

namespace tsubu_test {
inline int& failures() {
  static int n = 0;
  return n;
}
inline int& checks() {
  static int n = 0;
  return n;
}
inline int finish(const char* name) {
  std::printf("%s: %d checks, %d failed\n", name, checks(), failures());
  return failures() == 0 ? 0 : 1;
}
}  // namespace tsubu_test

#define CHECK(cond)                                                                   \
  do {                                                                                \
    ++tsubu_test::checks();                                                           \
    if (!(cond)) {                                                                    \
      ++tsubu_test::failures();                                                       \
      std::printf("%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);            \
    }                                                                                 \
  } while (0)

// |a - b| <= tol, printing both values on failure.
#define CHECK_CLOSE(a, b, tol)                                                         \
  do {                                                                                 \
    ++tsubu_test::checks();                                                            \
    const double va_ = (a), vb_ = (b);                                                 \
    if (!(std::abs(va_ - vb_) <= (tol))) {                                             \
      ++tsubu_test::failures();                                                        \
      std::printf("%s:%d: CHECK_CLOSE failed: %s = %.17g vs %s = %.17g (tol %g)\n",    \
                  __FILE__, __LINE__, #a, va_, #b, vb_, static_cast<double>(tol));    \
    }                                                                                  \
  } while (0)

#define CHECK_THROWS(expr, type)                                                      \
  do {                                                                                \
    ++tsubu_test::checks();                                                           \
    bool thrown_ = false;                                                             \
    try {                                                                             \
      expr;                                                                           \
    } catch (const type&) {                                                           \
      thrown_ = true;                                                                 \
    }                                                                                 \
    if (!thrown_) {                                                                   \
      ++tsubu_test::failures();                                                       \
      std::printf("%s:%d: expected %s from %s\n", __FILE__, __LINE__, #type, #expr);  \
    }                                                                                 \
  } while (0)
