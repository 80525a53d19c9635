// A periodic box and Lees–Edwards shear on the Simulation (domain.hpp, docs/periodic.md).
#include <algorithm>
#include <cmath>
#include <string>

#include "check.hpp"
#include "tsubu/archive.hpp"
#include "tsubu/simulation.hpp"

namespace tsubu {

using detail::fmt;
using detail::require;

namespace {
const char* const kAxis[3] = {"x", "y", "z"};
}

void Simulation::set_box(const Vec3& lower, const Vec3& upper, const std::array<bool, 3>& periodic) {
  if (running()) throw std::logic_error("tsubu: Simulation::set_box during a run");
  require(lower.allFinite() && upper.allFinite(), "box: lower and upper must be finite");
  for (int d = 0; d < 3; ++d)
    require(!periodic[d] || upper[d] > lower[d], [&] {
      return std::string("box: upper must exceed lower along the periodic axis ") + kAxis[d] + ", got " +
             fmt(lower[d]) + " to " + fmt(upper[d]);
    });
  if (domain_.sheared() && !(periodic[domain_.flow()] && periodic[domain_.gradient()]))
    domain_.set_shear(0, domain_.flow(), domain_.gradient());  // (kept only with its axes)
  domain_.set_box(lower, upper, periodic);
  if (domain_.periodic()) particles_.keep_images();
  domain_.clear_ghosts();
  particles_.drop_ghosts();
  lists_.valid = false;
  energy_ref_valid_ = false;
}

void Simulation::set_shear(double rate, int flow, int gradient) {
  if (running()) throw std::logic_error("tsubu: Simulation::set_shear during a run");
  require(std::isfinite(rate), "shear rate must be finite, got " + fmt(rate));
  require(flow >= 0 && flow < 3 && gradient >= 0 && gradient < 3 && flow != gradient,
          "shear: flow and gradient must be two different axes");
  require(domain_.periodic(flow) && domain_.periodic(gradient), [&] {
    return std::string("shear: the box must be periodic along the flow (") + kAxis[flow] + ") and the gradient (" +
           kAxis[gradient] + "): call set_box first";
  });
  const bool same = domain_.sheared() && domain_.flow() == flow && domain_.gradient() == gradient;
  domain_.set_shear(rate, flow, gradient);
  if (!same) {  // new images: the ghosts are made again
    domain_.clear_ghosts();
    particles_.drop_ghosts();
    lists_.valid = false;
  }
  energy_ref_valid_ = false;
}

void Simulation::check_box() const {
  if (!domain_.periodic() || particles_.size() == 0) return;
  const ParticleStore& p = particles_.arrays();
  const double rmax = *std::max_element(p.radius.begin(), p.radius.begin() + particles_.size());
  const double reach = 2 * rmax + skin();
  for (int d = 0; d < 3; ++d)
    require(!domain_.periodic(d) || domain_.length()[d] >= 2 * reach, [&] {
      return std::string("box: the periodic length along ") + kAxis[d] + " is " + fmt(domain_.length()[d]) +
             " m, less than twice the neighbour reach 2 (2 r_max + skin) = " + fmt(2 * reach) +
             " m: a sphere would meet two images of another; enlarge the box or reduce the skin";
    });
}

void Simulation::gather_wrapped(double* x, double* v) const {
  const ParticleStore& p = particles_.arrays();
  if (!domain_.periodic()) {
    if (x) particles_.gather(p.x.data(), x);
    if (v) particles_.gather(p.v.data(), v);
    return;
  }
  for (std::size_t k = 0; k < particles_.size(); ++k) {
    double xk[3], vk[3], slid = p.slid[k];
    int image[3];
    for (int c = 0; c < 3; ++c) xk[c] = p.x[3 * k + c], vk[c] = p.v[3 * k + c], image[c] = p.image[3 * k + c];
    domain_.wrap_one(xk, vk, image, &slid);
    const std::size_t row = particles_.rank(p.id[k]);
    for (int c = 0; c < 3; ++c) {
      if (x) x[3 * row + c] = xk[c];
      if (v) v[3 * row + c] = vk[c];
    }
  }
}

void Simulation::get_images(std::int64_t* out) const {
  const ParticleStore& p = particles_.arrays();
  if (!p.imaged) {  // (never periodic)
    std::fill(out, out + 3 * particles_.size(), std::int64_t(0));
    return;
  }
  for (std::size_t k = 0; k < particles_.size(); ++k) {
    double xk[3], vk[3], slid = p.slid[k];
    int image[3];
    for (int c = 0; c < 3; ++c) xk[c] = p.x[3 * k + c], vk[c] = p.v[3 * k + c], image[c] = p.image[3 * k + c];
    if (domain_.periodic()) domain_.wrap_one(xk, vk, image, &slid);
    const std::size_t row = particles_.rank(p.id[k]);
    for (int c = 0; c < 3; ++c) out[3 * row + c] = image[c];
  }
}

void Simulation::get_unwrapped_positions(double* out) const {
  const ParticleStore& p = particles_.arrays();
  for (std::size_t k = 0; k < particles_.size(); ++k) {
    const Vec3 u = domain_.unwrapped(vec3(p.x.data(), k), p, k);
    const std::size_t row = particles_.rank(p.id[k]);
    for (int c = 0; c < 3; ++c) out[3 * row + c] = u[c];
  }
}

void Simulation::set_pressure(double pressure, int axis, double gain, double max_rate) {
  if (running()) throw std::logic_error("tsubu: Simulation::set_pressure during a run");
  require(axis >= 0 && axis < 3, "pressure: axis must be 0, 1 or 2");
  require(domain_.periodic(axis), [&] {
    return std::string("pressure: the box must be periodic along the controlled axis ") + kAxis[axis] +
           ": call set_box first";
  });
  require(std::isfinite(pressure) && pressure > 0, "pressure must be > 0, got " + fmt(pressure));
  require(std::isfinite(gain) && gain > 0, "pressure gain must be > 0, got " + fmt(gain));
  require(std::isfinite(max_rate) && max_rate > 0, "max_strain_rate must be > 0, got " + fmt(max_rate));
  Domain::Servo s;
  s.on = true;
  s.axis = axis;
  s.pressure = pressure;
  s.gain = gain;
  s.max_rate = max_rate;
  domain_.set_servo(s);
  energy_ref_valid_ = false;
}

void Simulation::clear_pressure() {
  if (running()) throw std::logic_error("tsubu: Simulation::clear_pressure during a run");
  domain_.set_servo(Domain::Servo{});
}

double Simulation::box_pressure(int a) const {
  const ParticleStore& p = particles_.arrays();
  const std::size_t n = particles_.size();
  const Vec3 L = domain_.length();
  const double* x = p.x.data();
  const double* f = contacts_.pairs.force.data();
  const bool contacts = lists_.built(n) && contacts_.pairs.force.size() >= 3 * lists_.near_partner.size() &&
                        contacts_.pairs.touch.size() >= lists_.near_partner.size();
  // The mean flow of a Lees–Edwards box, if the axis is its flow: u = rate (x_g - centre).
  const bool streaming = domain_.sheared() && a == domain_.flow();
  const int g = domain_.gradient();
  const double centre = 0.5 * (domain_.lower()[g] + domain_.upper()[g]);
  double sum = 0;
  particles_.for_each_id([&](Id, Index i) {  // (id order: the same bits whatever the lists)
    const double v = p.v[3 * i + a] - (streaming ? domain_.shear_rate() * (x[3 * i + g] - centre) : 0.0);
    sum += p.mass[i] * v * v;
    if (!contacts) return;
    for (Index q = lists_.near_offset[i]; q < lists_.near_offset[i + 1]; ++q)
      if (contacts_.pairs.touch[q]) sum += f[3 * q + a] * (x[3 * i + a] - x[3 * lists_.near_partner[q] + a]);
  });
  return sum / (L[0] * L[1] * L[2]);
}

void Simulation::steer_box() {
  const Domain::Servo& s = domain_.servo();
  const double rate = std::clamp(s.gain * (box_pressure(s.axis) - s.pressure), -s.max_rate, s.max_rate);
  lists_.book_moved(domain_.stretch(particles_.arrays(), particles_.size(), rate, run_.dt));
}

void Simulation::save_periodic(archive::Writer& w) const {
  const Vec3 lo = domain_.lower(), hi = domain_.upper();
  w.reals("lower", {lo[0], lo[1], lo[2]});
  w.reals("upper", {hi[0], hi[1], hi[2]});
  w.integers("periodic", {domain_.periodic(0), domain_.periodic(1), domain_.periodic(2)});
  w.integer("sheared", domain_.sheared());
  w.integers("axes", {domain_.flow(), domain_.gradient()});
  w.real("rate", domain_.shear_rate());
  w.real("offset", domain_.shear_offset());
  const std::size_t n = particles_.size();
  std::vector<std::int64_t> image(3 * n);
  std::vector<double> slid(n);
  const ParticleStore& p = particles_.arrays();
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t row = particles_.rank(p.id[k]);
    for (int c = 0; c < 3; ++c) image[3 * row + c] = p.image[3 * k + c];
    slid[row] = p.slid[k];
  }
  w.integers("image", image);
  w.reals("slid", slid);
  w.real("moved", lists_.moved);
  w.real("moved_near", lists_.moved_near);
  w.real("skin", lists_.skin);
  const Domain::Servo& servo = domain_.servo();
  w.integers("servo", {servo.on, servo.axis});
  w.reals("servo_values", {servo.pressure, servo.gain, servo.max_rate});
}

void Simulation::restore_periodic(archive::Reader& r) {
  const std::vector<double> lo = r.reals("lower", 3), hi = r.reals("upper", 3);
  const std::vector<std::int64_t> per = r.integers("periodic", 3);
  const bool sheared = r.integer("sheared") != 0;
  const std::vector<std::int64_t> axes = r.integers("axes", 2);
  const double rate = r.real("rate"), offset = r.real("offset");
  for (std::int64_t a : axes)
    if (a < 0 || a > 2) r.fail("a shear axis " + std::to_string(a));
  set_box(Vec3(lo[0], lo[1], lo[2]), Vec3(hi[0], hi[1], hi[2]), {per[0] != 0, per[1] != 0, per[2] != 0});
  if (sheared) {
    set_shear(rate, static_cast<int>(axes[0]), static_cast<int>(axes[1]));
    domain_.set_shear_offset(offset);
  }
  const std::size_t n = particles_.size();
  const std::vector<std::int64_t> image = r.integers("image", 3 * n);
  const std::vector<double> slid = r.reals("slid", n);
  ParticleStore& p = particles_.arrays();
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t row = particles_.rank(p.id[k]);
    for (int c = 0; c < 3; ++c) p.image[3 * k + c] = static_cast<int>(image[3 * row + c]);
    p.slid[k] = slid[row];
  }
}

}  // namespace tsubu
