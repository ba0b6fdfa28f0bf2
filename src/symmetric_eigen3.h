// meshcvt: eigen-decomposition of a symmetric 3x3 matrix, shared by the quadric vertex placement
// (vertex_placement.cpp) and the principal axes of clusters cut by the coarsening fix loop
// (coarsen_mesh.cpp). Internal, not public API.
#pragma once

#include <cmath>

namespace meshcvt {

// Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations (converges
// quadratically; a handful of sweeps reach double precision). Column k of `vectors` belongs to
// values[k].
inline void symmetric_eigen3(const double m[3][3], double values[3], double vectors[3][3]) {
  double a[3][3], v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a[i][j] = m[i][j];
  for (int sweep = 0; sweep < 50; ++sweep) {
    double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    double diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
    if (off <= 1e-30 * diag || off == 0) break;
    for (int p = 0; p < 2; ++p) {
      for (int q = p + 1; q < 3; ++q) {
        if (a[p][q] == 0) continue;
        double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
        double t = (theta >= 0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1));
        double c = 1 / std::sqrt(t * t + 1), s = t * c;
        // A' = J^T A J with J the rotation in the (p, q) plane; V' = V J.
        for (int k = 0; k < 3; ++k) {
          double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {
          double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) {
          double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
    }
  }
  for (int k = 0; k < 3; ++k) {
    values[k] = a[k][k];
    for (int i = 0; i < 3; ++i) vectors[i][k] = v[i][k];
  }
}

}  // namespace meshcvt
