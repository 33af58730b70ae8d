// Acceptance checks on what surrounds a hypothesis (issue 9).
//
// Free space in front of a reference's surface: a match must not put target surface where
// the reference has none. A step (a floor and one wall, open beyond the floor's edge) fits half of
// a slot exactly, face for face; what tells them apart is the slot's other wall, standing where the
// step has open space. Rays leave the reference's surface along its outward normals; each runs
// through the reference's free space until it meets the reference again or leaves the reference's
// box (plus a margin). Mapped by a hypothesis, a ray that meets target surface before its free
// length is obstructed.
#pragma once

#include "featureextract/mesh.h"

#include <Eigen/Core>
#include <functional>
#include <vector>

namespace fe {

class Clearance {
 public:
  /// Distance from a point to the nearest sample of a surface.
  using Distance = std::function<double(const Eigen::Vector3d&)>;
  /// The nearest sample of a surface to a point (not finite when there is none).
  using Nearest = std::function<Eigen::Vector3d(const Eigen::Vector3d&)>;

  /// Rays from `rows` of the reference samples `points` along `normals` (outward), marched in steps
  /// of `step`; a ray stops where the reference (its nearest sample `reference_nearest`) comes within
  /// 1.5 `step`, or `margin` past the box lo..hi. Rays with no free length are dropped.
  Clearance(const Points& points, const Points& normals, const std::vector<Eigen::Index>& rows, const Nearest& reference_nearest,
            const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double step, double margin);

  /// Fraction of the rays that H (reference -> target) makes meet target surface (where
  /// `target_distance` falls below `target_hit`) before their free length, skipping the first `skip`
  /// (reference units) of each ray, where the target surface lies within the fit error. 0 if no rays.
  double obstructed(const Eigen::Matrix4d& H, const Distance& target_distance, double target_hit, double skip) const;

  std::size_t rays() const { return rays_.size(); }

 private:
  struct Ray {
    Eigen::Vector3d origin, direction;
    double free = 0;  // free length (reference units)
    double end = 0;   // where it met the reference again or left the box
    bool met = false; // it met the reference again
    // where it passes closest to the reference surface (past its own face): the ray's point and the
    // reference's, which a map may squeeze together (clear = INFINITY: nowhere)
    double clear = INFINITY;
    Eigen::Vector3d near_ray = Eigen::Vector3d::Zero(), near_reference = Eigen::Vector3d::Zero();
  };
  std::vector<Ray> rays_;
  double step_ = 0;
};

/// Whole faces: a reference face that is a whole B-rep face must land on a whole target face, not on
/// part of a larger one. A step mapped at 0.8x onto a slot lays its floor on 40 % of the slot's
/// floor: every sample lies on the target, but where the step's floor ends (at the part's side)
/// the slot's floor goes on. Areas are sample counts times the squared sample spacing, mapped by
/// Nanson's formula.
struct FaceCoverCheck {
  const Samples* reference = nullptr;      ///< reference dense samples (face_ids: 1-based B-rep faces)
  std::vector<Eigen::Index> rows;          ///< the samples to map (the feature's core)
  std::vector<char> checked;               ///< per reference face id: is it a whole face to check
  double reference_spacing = 0;            ///< reference sample spacing
  const Eigen::VectorXi* target_faces = nullptr;  ///< face of each target dense sample
  std::vector<double> target_area;         ///< per target face id: its area (samples x spacing^2)
  /// Nearest target dense sample to a point (index or -1), and its distance.
  std::function<int(const Eigen::Vector3d&, double*)> target_nearest;

  /// Optional: does target face g, which the checked reference face f lands on but covers less than
  /// `fill`, only go on past f's end at the reference's open border and leave the part where it ends
  /// (a through hole drilled through a taller boss than the reference's wall)? Such a face is not
  /// counted as partly covered.
  std::function<bool(const Eigen::Matrix4d& H, int f, int g)> goes_on_through;

  /// Share of the checked faces' samples whose target face is covered less than `fill` by the
  /// mapped reference (samples landing farther than `tol` from the target are not counted).
  double partial_share(const Eigen::Matrix4d& H, double tol, double fill) const;
};

}  // namespace fe
