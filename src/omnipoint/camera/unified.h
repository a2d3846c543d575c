#pragma once
// Shared pieces of the unified (spherical) camera models UCM, EUCM, DOUBLE_SPHERE and MEI,
// after Usenko, Demmel and Cremers, "The Double Sphere Camera Model" (3DV 2018), and Mei and
// Rives, "Single View Point Omnidirectional Camera Calibration from Planar Grids" (ICRA 2007).
//
// EUCM projects pixel = f (x, y) / (α d + (1 − α) z) + c with d = sqrt(β (x² + y²) + z²);
// UCM is EUCM with β = 1, MEI is UCM written with ξ = α / (1 − α) and f_mei = f / (1 − α),
// DOUBLE_SPHERE applies UCM to the point moved to the unit sphere and shifted by ξ along z.
// The projection is injective exactly where z > −w d with w = α / (1 − α) for α <= 0.5 and
// w = (1 − α) / α otherwise; for α > 0.5 that boundary is a fold at finite pixel radius,
// where unprojection needs (2α − 1) β r² <= 1.
#include <string>
#include <vector>

#include "omnipoint/camera/camera_model.h"
#include "omnipoint/camera/lens_helpers.h"

namespace omnipoint::camera {

// w of the projection domain z > −w d, for α in [0, 1].
double unified_domain_weight(double alpha);

// The z of the EUCM unprojection (m_x, m_y, m_z) for r² = |m|², with the validity
// (2α − 1) β r² <= 1 + slack. Written to stay exact for every α in [0, 1], including α = 1.
struct PlaneDepth {
  at::Tensor mz;
  at::Tensor valid;
};
PlaneDepth eucm_plane_depth(const at::Tensor& r2, double alpha, const at::Tensor& beta,
                            double slack);

// The unit vector s with s + (0, 0, ξ) on the ray through (m_x, m_y, m_z) (..., 3), for
// |ξ| <= 1 or m_z = 1: the inverse of the "shift the unit sphere by ξ" step of MEI and
// DOUBLE_SPHERE. valid where the ray meets that sphere (touching it within `slack`).
Rays lift_to_shifted_sphere(const at::Tensor& m, const at::Tensor& xi, double slack);

}  // namespace omnipoint::camera
