// The checkpoint archive's records (archive.hpp).
#include "tsubu/archive.hpp"

#include <cstring>

namespace tsubu::archive {

namespace {

bool little_endian() {
  const std::uint16_t one = 1;
  unsigned char first;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

// n values of 8 bytes each, from host order to little-endian (or back: the same swap).
void put8(std::string& out, const void* from, std::size_t n) {
  const std::size_t at = out.size();
  out.resize(at + 8 * n);
  std::memcpy(&out[at], from, 8 * n);
  if (!little_endian())
    for (std::size_t k = 0; k < n; ++k)
      for (int b = 0; b < 4; ++b) std::swap(out[at + 8 * k + b], out[at + 8 * k + 7 - b]);
}

void get8(const char* from, void* to, std::size_t n) {
  std::memcpy(to, from, 8 * n);
  if (!little_endian()) {
    auto* p = static_cast<char*>(to);
    for (std::size_t k = 0; k < n; ++k)
      for (int b = 0; b < 4; ++b) std::swap(p[8 * k + b], p[8 * k + 7 - b]);
  }
}

const char* type_name(Type t) {
  switch (t) {
    case Type::Real: return "reals";
    case Type::Integer: return "integers";
    case Type::Bytes: return "bytes";
    case Type::Section: return "a section";
  }
  return "an unknown type";
}

}  // namespace

void Writer::head(Type type, const std::string& name, std::uint64_t count) {
  if (name.size() > 0xffff) throw InvalidArgument("checkpoint: record name too long: " + name);
  out_.push_back(static_cast<char>(type));
  out_.push_back(static_cast<char>(name.size() & 0xff));
  out_.push_back(static_cast<char>(name.size() >> 8));
  out_ += name;
  put8(out_, &count, 1);
}

void Writer::reals(const std::string& name, const double* v, std::size_t n) {
  head(Type::Real, name, n);
  if (n) put8(out_, v, n);
}

void Writer::integers(const std::string& name, const std::int64_t* v, std::size_t n) {
  head(Type::Integer, name, n);
  if (n) put8(out_, v, n);
}

void Writer::bytes(const std::string& name, const std::string& v) {
  head(Type::Bytes, name, v.size());
  out_ += v;
}

void Writer::section(const std::string& name, const Writer& inner) {
  head(Type::Section, name, inner.out_.size());
  out_ += inner.out_;
}

void Reader::fail(const std::string& what) const {
  throw InvalidArgument("checkpoint: " + (where_.empty() ? "" : "section " + where_ + ": ") + what);
}

std::uint64_t Reader::open(Type type, const std::string& name, std::size_t size) {
  const std::string& d = *data_;
  if (at_ == end_) fail("record '" + name + "' is missing (the data ends before it: truncated?)");
  if (end_ - at_ < 3) fail("truncated before record '" + name + "'");
  const auto t = static_cast<Type>(static_cast<unsigned char>(d[at_]));
  const std::size_t length = static_cast<unsigned char>(d[at_ + 1]) |
                             (static_cast<std::size_t>(static_cast<unsigned char>(d[at_ + 2])) << 8);
  if (end_ - at_ - 3 < length + 8) fail("truncated in the header of the record expected as '" + name + "'");
  const std::string found = d.substr(at_ + 3, length);
  if (found != name)
    fail("expected record '" + name + "', found '" + found + "' (a file of another layout?)");
  if (t != type)
    fail("record '" + name + "' holds " + type_name(t) + ", expected " + type_name(type));
  std::uint64_t count;
  get8(d.data() + at_ + 3 + length, &count, 1);
  at_ += 3 + length + 8;
  if (count > (end_ - at_) / size)
    fail("record '" + name + "' needs " + std::to_string(count) + " x " + std::to_string(size) +
         " bytes, " + std::to_string(end_ - at_) + " remain (truncated?)");
  return count;
}

std::vector<double> Reader::reals(const std::string& name) {
  const std::uint64_t n = open(Type::Real, name, 8);
  std::vector<double> v(n);
  if (n) get8(data_->data() + at_, v.data(), n);
  at_ += 8 * n;
  return v;
}

std::vector<double> Reader::reals(const std::string& name, std::size_t n) {
  std::vector<double> v = reals(name);
  if (v.size() != n)
    fail("record '" + name + "' has " + std::to_string(v.size()) + " values, expected " + std::to_string(n));
  return v;
}

double Reader::real(const std::string& name) { return reals(name, 1)[0]; }

Vec3 Reader::vec3(const std::string& name) {
  const std::vector<double> v = reals(name, 3);
  return Vec3(v[0], v[1], v[2]);
}

std::vector<std::int64_t> Reader::integers(const std::string& name) {
  const std::uint64_t n = open(Type::Integer, name, 8);
  std::vector<std::int64_t> v(n);
  if (n) get8(data_->data() + at_, v.data(), n);
  at_ += 8 * n;
  return v;
}

std::vector<std::int64_t> Reader::integers(const std::string& name, std::size_t n) {
  std::vector<std::int64_t> v = integers(name);
  if (v.size() != n)
    fail("record '" + name + "' has " + std::to_string(v.size()) + " values, expected " + std::to_string(n));
  return v;
}

std::int64_t Reader::integer(const std::string& name) { return integers(name, 1)[0]; }

std::string Reader::bytes(const std::string& name) {
  const std::uint64_t n = open(Type::Bytes, name, 1);
  std::string s = data_->substr(at_, n);
  at_ += n;
  return s;
}

Reader Reader::section(const std::string& name) {
  const std::uint64_t n = open(Type::Section, name, 1);
  Reader inner(*data_, at_, at_ + n, where_.empty() ? name : where_ + "/" + name);
  at_ += n;
  return inner;
}

bool Reader::next_is(const std::string& name) const {
  const std::string& d = *data_;
  if (end_ - at_ < 3) return false;
  const std::size_t length = static_cast<unsigned char>(d[at_ + 1]) |
                             (static_cast<std::size_t>(static_cast<unsigned char>(d[at_ + 2])) << 8);
  return end_ - at_ - 3 >= length && d.compare(at_ + 3, length, name) == 0;
}

void Reader::finish() const {
  if (at_ != end_)
    fail(std::to_string(end_ - at_) + " bytes left unread after the last record expected "
         "(written by a newer tsubu, or damaged)");
}

}  // namespace tsubu::archive
