// Pinocchio's articulated-body algorithm (aba) on a chain read from a table, timed in C++:
// the thread's CPU time per call, the minimum over rounds of many calls. Used by
// benchmarks/bench_pinocchio.py, which writes the table (one line per link: parent axis(3)
// origin(3) mass com(3) inertia about the centre of mass (xx yy zz xy xz yz)) and the state.
#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/aba.hpp>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <vector>

static double cpu_now() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

int main(int argc, char **argv) {
  if (argc < 4) { std::cerr << "usage: pinocchio_aba TABLE STATE REPS\n"; return 2; }
  std::ifstream table(argv[1]);
  int n; double g;
  table >> n >> g;
  pinocchio::Model model;
  model.gravity.linear() << 0.0, 0.0, -g;
  pinocchio::JointIndex parent = 0;
  for (int i = 0; i < n; ++i) {
    int p; double a[3], o[3], m, c[3], I[6];
    table >> p >> a[0] >> a[1] >> a[2] >> o[0] >> o[1] >> o[2] >> m >> c[0] >> c[1] >> c[2]
          >> I[0] >> I[1] >> I[2] >> I[3] >> I[4] >> I[5];
    pinocchio::SE3 placement(Eigen::Matrix3d::Identity(), Eigen::Vector3d(o[0], o[1], o[2]));
    parent = model.addJoint(p < 0 ? 0 : parent,
                            pinocchio::JointModelRevoluteUnaligned(a[0], a[1], a[2]), placement,
                            "j" + std::to_string(i));
    Eigen::Matrix3d Ic;
    Ic << I[0], I[3], I[4], I[3], I[1], I[5], I[4], I[5], I[2];
    model.appendBodyToJoint(parent, pinocchio::Inertia(m, Eigen::Vector3d(c[0], c[1], c[2]), Ic),
                            pinocchio::SE3::Identity());
  }
  pinocchio::Data data(model);
  Eigen::VectorXd q(model.nq), v(model.nv), tau = Eigen::VectorXd::Zero(model.nv);
  std::ifstream state(argv[2]);
  for (int i = 0; i < model.nq; ++i) state >> q[i];
  for (int i = 0; i < model.nv; ++i) state >> v[i];
  const int reps = std::atoi(argv[3]);
  double best = 1e9;
  for (int r = 0; r < 30; ++r) {
    const double t0 = cpu_now();
    for (int k = 0; k < reps; ++k) {
      q[0] += 1e-15;
      pinocchio::aba(model, data, q, v, tau);
    }
    best = std::min(best, (cpu_now() - t0) / reps);
  }
  std::printf("%.6e", best);
  for (int i = 0; i < model.nv; ++i) std::printf(" %.17g", data.ddq[i]);
  std::printf("\n");
  return 0;
}
