// Compiled Pinocchio on the arm's 7-joint model: the anchor of bench_dynamics.py.
//
// Usage: pinocchio_anchor MODEL STATES N REPEATS OUT
//   MODEL   text: 7 lines "d a alpha offset mass cx cy cz Ixx Ixy Ixz Iyy Iyz Izz" (m, rad, kg,
//           inertia about the centre of mass in DH frame i, kg·m²), then "gx gy gz" (m/s²)
//   STATES  float64 binary: q, qd, qdd, each (N, 7), one after the other (rad, rad/s, rad/s²)
//   OUT     float64 binary written here: tau (N, 7), M (N, 7, 7) symmetrised, G (N, 7)
// Prints "rnea", "crba" and "gravity" with the best of REPEATS timed passes over the N states, in
// µs per sample. The model is built as baxter_dynamics_ros/core/pinocchio_model.py builds it.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <limits>
#include <vector>

#include "pinocchio/algorithm/crba.hpp"
#include "pinocchio/algorithm/rnea.hpp"
#include "pinocchio/multibody.hpp"

namespace {

constexpr int kJoints = 7;
using Vector7 = Eigen::Matrix<double, kJoints, 1>;
using Map7 = Eigen::Map<const Vector7>;

pinocchio::Model build_model(const char * path) {
  std::ifstream in(path);
  pinocchio::Model model;
  pinocchio::JointIndex joint = 0;
  pinocchio::SE3 placement = pinocchio::SE3::Identity();
  for (int i = 0; i < kJoints; ++i) {
    double d, a, alpha, offset, mass, c[3], I[6];
    in >> d >> a >> alpha >> offset >> mass >> c[0] >> c[1] >> c[2];
    for (double & x : I) in >> x;
    joint = model.addJoint(joint, pinocchio::JointModelRZ(), placement, "joint" + std::to_string(i + 1));
    const pinocchio::SE3 rz(Eigen::AngleAxisd(offset, Eigen::Vector3d::UnitZ()).toRotationMatrix(), Eigen::Vector3d::Zero());
    const pinocchio::SE3 rx(Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitX()).toRotationMatrix(), Eigen::Vector3d(a, 0.0, d));
    placement = rz * rx;
    Eigen::Matrix3d inertia;
    inertia << I[0], I[1], I[2], I[1], I[3], I[4], I[2], I[4], I[5];
    model.appendBodyToJoint(joint, pinocchio::Inertia(mass, Eigen::Vector3d(c[0], c[1], c[2]), inertia), placement);
  }
  double g[3];
  in >> g[0] >> g[1] >> g[2];
  if (!in) {
    std::cerr << "ERROR: cannot read the model from " << path << "\n";
    std::exit(1);
  }
  model.gravity.linear(Eigen::Vector3d(g[0], g[1], g[2]));
  return model;
}

template <typename Body>
double best_us_per_sample(int n, int repeats, Body body) {
  double best = std::numeric_limits<double>::infinity();
  for (int r = 0; r < repeats; ++r) {
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < n; ++i) body(i);
    const std::chrono::duration<double, std::micro> took = std::chrono::steady_clock::now() - start;
    best = std::min(best, took.count() / n);
  }
  return best;
}

}  // namespace

int main(int argc, char ** argv) {
  if (argc != 6) {
    std::cerr << "usage: pinocchio_anchor MODEL STATES N REPEATS OUT\n";
    return 2;
  }
  const pinocchio::Model model = build_model(argv[1]);
  pinocchio::Data data(model);
  const int n = std::atoi(argv[3]);
  const int repeats = std::atoi(argv[4]);
  std::vector<double> states(3 * static_cast<size_t>(n) * kJoints);
  std::ifstream in(argv[2], std::ios::binary);
  in.read(reinterpret_cast<char *>(states.data()), static_cast<std::streamsize>(states.size() * sizeof(double)));
  if (!in || n <= 0 || repeats <= 0) {
    std::cerr << "ERROR: cannot read " << n << " states from " << argv[2] << "\n";
    return 1;
  }
  const double * q = states.data();
  const double * qd = q + static_cast<size_t>(n) * kJoints;
  const double * qdd = qd + static_cast<size_t>(n) * kJoints;
  auto at = [](const double * base, int i) { return Map7(base + static_cast<size_t>(i) * kJoints); };

  // Results, once, untimed: for the bench to check that this is the same model.
  std::vector<double> out(static_cast<size_t>(n) * (kJoints + kJoints * kJoints + kJoints));
  double * tau_out = out.data();
  double * m_out = tau_out + static_cast<size_t>(n) * kJoints;
  double * g_out = m_out + static_cast<size_t>(n) * kJoints * kJoints;
  for (int i = 0; i < n; ++i) {
    Eigen::Map<Vector7>(tau_out + i * kJoints) = pinocchio::rnea(model, data, at(q, i), at(qd, i), at(qdd, i));
    pinocchio::crba(model, data, at(q, i));
    data.M.triangularView<Eigen::StrictlyLower>() = data.M.transpose().triangularView<Eigen::StrictlyLower>();
    Eigen::Map<Eigen::Matrix<double, kJoints, kJoints, Eigen::RowMajor>>(m_out + i * kJoints * kJoints) = data.M;
    Eigen::Map<Vector7>(g_out + i * kJoints) = pinocchio::computeGeneralizedGravity(model, data, at(q, i));
  }
  std::ofstream dump(argv[5], std::ios::binary);
  dump.write(reinterpret_cast<const char *>(out.data()), static_cast<std::streamsize>(out.size() * sizeof(double)));

  // Timed passes; the checksum keeps the compiler from dropping the work.
  double checksum = 0.0;
  const double rnea_us = best_us_per_sample(n, repeats, [&](int i) {
    checksum += pinocchio::rnea(model, data, at(q, i), at(qd, i), at(qdd, i))[0];
  });
  const double crba_us = best_us_per_sample(n, repeats, [&](int i) {
    checksum += pinocchio::crba(model, data, at(q, i))(0, kJoints - 1);
  });
  const double gravity_us = best_us_per_sample(n, repeats, [&](int i) {
    checksum += pinocchio::computeGeneralizedGravity(model, data, at(q, i))[0];
  });
  std::printf("rnea %.6f\ncrba %.6f\ngravity %.6f\nchecksum %.17g\n", rnea_us, crba_us, gravity_us, checksum);
  return 0;
}
