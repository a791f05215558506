#pragma once
// The isotropic and the anisotropic Laplacian of Lange & Polthier (2005), Sections 2.3 and 4,
// with the sharp and the continuous cut-off of Section 5:
//   A_i = (1 / |N_i|) sum_j g_ij (p_j - p_i)
//   g_sharp = 1 if |kappa_ij| < lambda else 0
//   g_cont  = 1 if |kappa_ij| < lambda else lambda^2 / (lambda^2 + 10 (|kappa_ij| - lambda)^2)
// Isotropic: all g_ij = 1 (the umbrella operator).
//
// Differs from the paper: the umbrella points toward the neighbours (the paper's
// sum (f(p_i) - f(p_j)) with S + lambda dt Delta S would push points apart), the cut-off uses
// |kappa| (PCA normals have no sign), and the sum is divided by |N_i|, not by sum g, so a
// point whose neighbours are all cut off (a corner) stays where it is (the paper's Figure 4).
#include <span>

#include "pointfair/types.hpp"

namespace pointfair {

enum class Flow { Isotropic, Anisotropic };
enum class Cutoff { Sharp, Continuous };

/// Cut-off weight g for a directional curvature of magnitude abs_kappa and threshold lambda
/// (both 1/length).
inline double cutoff_weight(double abs_kappa, double lambda, Cutoff cutoff) {
  if (abs_kappa < lambda) return 1.0;
  if (cutoff == Cutoff::Sharp) return 0.0;
  const double excess = abs_kappa - lambda;
  return lambda * lambda / (lambda * lambda + 10.0 * excess * excess);
}

struct LaplacianParams {
  Flow flow = Flow::Anisotropic;
  Cutoff cutoff = Cutoff::Sharp;
  /// Curvature threshold of the cut-off (1/length). Ignored by the isotropic flow.
  double lambda = 1.0;
};

/// A_i of point p with unit normal `normal` (sign irrelevant) and neighbours `neighbors`.
/// Returns the zero vector for an empty neighbourhood.
Vec3 laplacian(const Vec3& p, const Vec3& normal, std::span<const Index> neighbors,
               std::span<const Vec3> points, const LaplacianParams& params);

}  // namespace pointfair
