// The radiosity pipeline's view of a session's scene model (core/scene_model.h): the scene's
// geometry as a radiosity mesh (one material per object, values unknown), the lamps at a given
// instant, and which patch each camera pixel sees.
//
// Conventions:
//  - The model's triangles may wind either way; radiosity triangles are one-sided
//    (radiosity/scene.h). A surface's triangles are turned to face the centre of the scene's
//    bounding box (a closed room seen from inside); every triangle of a solid is turned away
//    from its object's centre (closed objects seen from outside). Solids' faces lying on the
//    floor, facing down, are left out.
//  - Materials are per object, named after it, or per user-given group of objects known to share
//    one material (e.g. walls painted alike); their albedo is a prior (0.5), never the scene's.
//    An object whose faces carry several scene model materials (a ColorChecker: frame and 24
//    patches) gets one radiosity material per scene model material, named after that.
//  - `known_albedo` per radiosity material: the scene model material's known reflectance (a
//    chart's reference values) where it has one. Only a radiometric reference (the absolute scale
//    from a chart) reads it; the reflectance estimate still measures every material.
//  - Pixel centres at (u + 0.5, v + 0.5) as in core/pinhole.h and the sim renderer; a pixel's
//    patch is the leaf hit by its centre ray (-1: no surface).
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/pinhole.h"
#include "core/scene_model.h"
#include "core/time.h"
#include "processing/radiosity/geometry.h"
#include "processing/radiosity/hierarchy.h"
#include "processing/radiosity/scene.h"

namespace relume::pipeline {

struct RadiosityScene {
  radiosity::Mesh mesh;
  std::vector<int> object_material;   // per scene model object: index into mesh.materials (its first face's)
  std::vector<int> object_triangles;  // per object: its mesh triangles (contiguous, in object order)
  std::vector<int> triangle_object;   // per mesh triangle: the scene model object it came from
  std::vector<int> triangle_face;     // per mesh triangle: its index in that object's triangles
  std::vector<std::optional<Eigen::Vector3d>> known_albedo;  // per mesh material (see above)
};

// `material_groups`: "a+b,c+d" puts objects a and b in one material, c and d in another.
// Throws InvalidArgumentError naming the object for geometry the pipeline cannot model
// (spheres) and for unknown object names in the groups.
RadiosityScene RadiositySceneFromModel(const SceneModel& model, const std::string& material_groups = "");

// Every lamp of the model at `utc` (where its track puts it; spots keep their cone).
radiosity::Lighting LightingAt(const SceneModel& model, UtcTime utc);

// The leaf patch containing point `p` of mesh triangle `triangle`.
int PatchAt(const radiosity::PatchHierarchy& hierarchy, int triangle, const Eigen::Vector3d& p);

// CV_32SC1: the patch each pixel's centre ray hits first (-1 where it hits nothing). With
// `points_m`, also where it hits it (CV_32FC3, scene metres; NaN where the id is -1).
cv::Mat PatchIdImage(const radiosity::PatchHierarchy& hierarchy, const RayCaster& caster, const PinholeCamera& camera,
                     cv::Mat* points_m = nullptr);

}  // namespace relume::pipeline
