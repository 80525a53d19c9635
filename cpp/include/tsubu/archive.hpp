// A small binary archive for checkpoints (docs/checkpoints.md, "The core's bytes"): a sequence of
// named, typed, length-prefixed records, little-endian. A record is
//
//   type   1 byte    Real (f64), Integer (i64), Bytes (a string), Section (nested records)
//   name   2 bytes length, then the name's bytes
//   count  8 bytes   values (Real, Integer), bytes (Bytes, Section)
//   data             count values of 8 bytes, or count bytes
//
// A part of the Simulation writes its state as a Section of its own (save(Writer&)) and reads it
// back in the same order (restore(Reader&)). The Reader checks each record's name and type, that
// no record runs past the end, and (finish()) that every byte of a section was read: a truncated,
// reordered or foreign stream fails with an InvalidArgument naming the section and the record.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "types.hpp"

namespace tsubu::archive {

enum class Type : std::uint8_t { Real = 1, Integer = 2, Bytes = 3, Section = 4 };

class Writer {
 public:
  void real(const std::string& name, double v) { reals(name, &v, 1); }
  void integer(const std::string& name, std::int64_t v) { integers(name, &v, 1); }
  void reals(const std::string& name, const double* v, std::size_t n);
  void reals(const std::string& name, const std::vector<double>& v) { reals(name, v.data(), v.size()); }
  void vec3(const std::string& name, const Vec3& v) { reals(name, v.data(), 3); }
  void integers(const std::string& name, const std::int64_t* v, std::size_t n);
  void integers(const std::string& name, const std::vector<std::int64_t>& v) {
    integers(name, v.data(), v.size());
  }
  void bytes(const std::string& name, const std::string& v);
  // A nested section holding `inner`'s records.
  void section(const std::string& name, const Writer& inner);
  const std::string& data() const { return out_; }

 private:
  void head(Type type, const std::string& name, std::uint64_t count);
  std::string out_;
};

class Reader {
 public:
  // Reads the records in `data` (kept by reference: it must outlive the Reader and its
  // sections' Readers). Messages name the section path ("materials/material").
  explicit Reader(const std::string& data) : Reader(data, 0, data.size(), "") {}

  double real(const std::string& name);
  std::int64_t integer(const std::string& name);
  std::vector<double> reals(const std::string& name);
  // Exactly n values (an InvalidArgument naming the record otherwise).
  std::vector<double> reals(const std::string& name, std::size_t n);
  Vec3 vec3(const std::string& name);
  std::vector<std::int64_t> integers(const std::string& name);
  std::vector<std::int64_t> integers(const std::string& name, std::size_t n);
  std::string bytes(const std::string& name);
  Reader section(const std::string& name);
  // Whether the next record is named `name` (an optional record).
  bool next_is(const std::string& name) const;
  // Throws unless every record was read.
  void finish() const;
  // Throws an InvalidArgument: "checkpoint: section <path>: <what>".
  [[noreturn]] void fail(const std::string& what) const;

 private:
  Reader(const std::string& data, std::size_t begin, std::size_t end, std::string where)
      : data_(&data), at_(begin), end_(end), where_(std::move(where)) {}
  // The next record's header, checked to be `name` of `type`; returns its count, leaves at_ at
  // its data, and checks that `count * size` bytes follow.
  std::uint64_t open(Type type, const std::string& name, std::size_t size);
  const std::string* data_;
  std::size_t at_, end_;
  std::string where_;
};

}  // namespace tsubu::archive
