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
/// Where the directional curvatures of the cut-off are measured from: the point itself (the
/// paper: kappa_ij = 2 <n_i, p_j - p_i> / |p_j - p_i|^2), or its foot on the fitted tangent
/// plane (the PCA plane through the barycentre of {p_i} ∪ N_i). Measured from the point, a
/// point lifted off the surface by noise sees a large |kappa| toward exactly the neighbours that
/// would pull it back, so the cut-off keeps the neighbours at its own height; from the foot, the
/// point's own offset does not decide which neighbours are kept (the motion is unchanged:
/// still toward p_j - p_i).
enum class CutoffOrigin { Point, Plane };

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
  /// Signed distance (length) along `normal` from p to the origin of the directional
  /// curvatures of the cut-off: 0 measures them from p (the paper); <n, c - p> with c the
  /// barycentre measures them from p's foot on the PCA plane (CutoffOrigin::Plane). Sign-free:
  /// flipping the normal flips this distance too.
  double origin_height = 0.0;
};

/// A_i of point p with unit normal `normal` (sign irrelevant) and neighbours `neighbors`.
/// Returns the zero vector for an empty neighbourhood.
Vec3 laplacian(const Vec3& p, const Vec3& normal, std::span<const Index> neighbors,
               std::span<const Vec3> points, const LaplacianParams& params);

}  // namespace pointfair
