// meshcvt: eigen-decomposition of a symmetric 3x3 matrix, shared by the quadric vertex placement
// (vertex_placement.cpp), the principal axes of clusters cut by the coarsening fix loop
// (coarsen_mesh.cpp) and the free directions of coarse relax (coarse_relax.cpp). Internal, not
// public API.
#pragma once

#include <cmath>

namespace meshcvt {

// Eigen-decompositions of `count` (<= N) symmetric 3x3 matrices side by side, by cyclic Jacobi
// rotations (converges quadratically; a handful of sweeps reach double precision). Column k of
// vectors[i] belongs to values[i][k]. Each matrix (lane) goes through its own operations in its
// own order and stops at its own test, so its result does not depend on the other lanes; they are
// only interleaved: a rotation is a chain of ~100 cycles of dependent divisions and square roots,
// which the other lane's chain fills (coarse relax's rings on fandisk: 250 ns per matrix alone,
// 150 in pairs; four lanes did no better).
template <int N>
inline void symmetric_eigen3_lanes(int count, const double m[][3][3], double values[][3], double vectors[][3][3]) {
  double a[N][3][3], v[N][3][3];
  bool done[N];
  for (int lane = 0; lane < N; ++lane) {
    done[lane] = lane >= count;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        a[lane][i][j] = lane < count ? m[lane][i][j] : 0;
        v[lane][i][j] = i == j ? 1 : 0;
      }
  }
  for (int sweep = 0; sweep < 50; ++sweep) {
    bool rotating = false;
    for (int lane = 0; lane < N; ++lane) {
      if (done[lane]) continue;
      const double(&A)[3][3] = a[lane];
      double off = A[0][1] * A[0][1] + A[0][2] * A[0][2] + A[1][2] * A[1][2];
      double diag = A[0][0] * A[0][0] + A[1][1] * A[1][1] + A[2][2] * A[2][2];
      done[lane] = off <= 1e-30 * diag || off == 0;
      rotating = rotating || !done[lane];
    }
    if (!rotating) break;
    for (int p = 0; p < 2; ++p) {
      for (int q = p + 1; q < 3; ++q) {
        for (int lane = 0; lane < N; ++lane) {
          double(&A)[3][3] = a[lane];
          double(&V)[3][3] = v[lane];
          if (done[lane] || A[p][q] == 0) continue;
          double theta = (A[q][q] - A[p][p]) / (2 * A[p][q]);
          double t = (theta >= 0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1));
          double c = 1 / std::sqrt(t * t + 1), s = t * c;
          // A' = J^T A J with J the rotation in the (p, q) plane; V' = V J.
          for (int k = 0; k < 3; ++k) {
            double akp = A[k][p], akq = A[k][q];
            A[k][p] = c * akp - s * akq;
            A[k][q] = s * akp + c * akq;
          }
          for (int k = 0; k < 3; ++k) {
            double apk = A[p][k], aqk = A[q][k];
            A[p][k] = c * apk - s * aqk;
            A[q][k] = s * apk + c * aqk;
          }
          for (int k = 0; k < 3; ++k) {
            double vkp = V[k][p], vkq = V[k][q];
            V[k][p] = c * vkp - s * vkq;
            V[k][q] = s * vkp + c * vkq;
          }
        }
      }
    }
  }
  for (int lane = 0; lane < count; ++lane)
    for (int k = 0; k < 3; ++k) {
      values[lane][k] = a[lane][k][k];
      for (int i = 0; i < 3; ++i) vectors[lane][i][k] = v[lane][i][k];
    }
}

// One matrix: the same operations as a lane above.
inline void symmetric_eigen3(const double m[3][3], double values[3], double vectors[3][3]) {
  double lane_m[1][3][3], lane_values[1][3], lane_vectors[1][3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) lane_m[0][i][j] = m[i][j];
  symmetric_eigen3_lanes<1>(1, lane_m, lane_values, lane_vectors);
  for (int k = 0; k < 3; ++k) {
    values[k] = lane_values[0][k];
    for (int i = 0; i < 3; ++i) vectors[i][k] = lane_vectors[0][i][k];
  }
}

}  // namespace meshcvt
