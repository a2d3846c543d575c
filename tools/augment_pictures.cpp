// Renders the pictures of docs/AUGMENTATION.md: a synthetic pinhole sample turned into a
// fisheye and a panorama (P2A), an A2P pseudo-label and a multi-view merge, with the
// renderer as the oracle teacher. Usage: augment_pictures OUT_DIR
#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>

#include <cmath>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "omnipoint/augment/a2p.h"
#include "omnipoint/augment/p2a.h"
#include "omnipoint/augment/virtual_camera.h"
#include "omnipoint/augment/warp.h"
#include "omnipoint/data/synth/render.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/geometry/colormap.h"
#include "omnipoint/io/image.h"

using namespace omnipoint;

namespace {

at::Tensor grey(const at::Tensor& mask) {
  return mask.to(at::kFloat).unsqueeze(-1).expand({-1, -1, 3});
}

// image | distance (Turbo on inverse distance) | mask, side by side with a 4-pixel gap.
at::Tensor panels(const std::vector<at::Tensor>& images, int64_t dim) {
  std::vector<at::Tensor> parts;
  for (const auto& image : images) {
    if (!parts.empty()) {
      auto gap_shape = image.sizes().vec();
      gap_shape[dim] = 4;
      parts.push_back(at::ones(gap_shape, at::kFloat));
    }
    parts.push_back(image.to(at::kFloat));
  }
  return at::cat(parts, dim);
}

at::Tensor row(const at::Tensor& image, const at::Tensor& distance, const at::Tensor& mask,
               int64_t dim = 1) {
  return panels({image, geometry::colorize_depth(distance, mask), grey(mask)}, dim);
}

augment::Teacher oracle(const data::synth::Scene& scene, const at::Tensor& rotation, double scale) {
  return [scene, rotation, scale](const at::Tensor&, const camera::Camera& cam) {
    const auto rays = cam.ray_map(at::kDouble);
    data::synth::RenderOptions options;
    options.shadows = options.ambient_occlusion = false;
    const auto r =
        data::synth::render_scene(scene, rays.rays.matmul(rotation.t()), rays.valid, options);
    return augment::TeacherPrediction{rays.rays.to(at::kFloat), (r.distance * scale).to(at::kFloat),
                                      r.mask};
  };
}

}  // namespace

int run(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: augment_pictures OUT_DIR\n";
    return 1;
  }
  const std::string out = argv[1];
  using data::synth::SceneKind;
  data::synth::SynthOptions fast;
  fast.render.ambient_occlusion = false;

  // P2A: one pinhole sample into a 200-degree fisheye and a full panorama.
  const auto pinhole = camera::centred_pinhole(90, 320, 240);
  const auto source = data::synth::synthesize(SceneKind::kIndoor, 1, pinhole, fast);
  io::write_image_png(out + "/p2a_source.png",
                      row(source.sample.image, source.sample.distance, source.sample.mask));
  const auto fisheye = augment::fisheye_with_fov("DOUBLE_SPHERE", 240, 240, 200, {-0.1, 0.6});
  const auto fish = augment::perspective_to_any(
      pinhole, source.sample.image, source.sample.distance, source.sample.mask,
      {fisheye, augment::rotation_from_angles(0, 0, 0), {}});
  io::write_image_png(out + "/p2a_fisheye.png",
                      row(fish.image, fish.distance * fish.mask, fish.mask));
  const camera::Camera pano("EQUIRECTANGULAR", 384, 192, {});
  const auto p = augment::perspective_to_any(pinhole, source.sample.image, source.sample.distance,
                                             source.sample.mask,
                                             {pano, augment::rotation_from_angles(0, 0, 0), {}});
  io::write_image_png(out + "/p2a_panorama.png", row(p.image, p.distance * p.mask, p.mask, 0));

  // A2P: one pinhole view of an unlabeled panorama, its (oracle) prediction, the pseudo-label.
  const auto wide = data::synth::synthesize(SceneKind::kOutdoor, 2, pano, fast);
  const auto view = augment::make_perspective_view(75, 40, 5, 160, 120);
  const auto a2p = augment::any_to_perspective(pano, wide.sample.image, view,
                                               oracle(wide.scene, view.rotation, 1.0));
  io::write_image_png(
      out + "/a2p_view.png",
      panels({a2p.extracted.image,
              geometry::colorize_depth(a2p.prediction.distance, a2p.prediction.confident)},
             1));
  io::write_image_png(
      out + "/a2p_pseudolabel.png",
      panels({wide.sample.image, geometry::colorize_depth(a2p.label.distance, a2p.label.mask),
              grey(a2p.label.mask)},
             0));

  // Multi-view: 18 views, each answered at a random scale, merged into one panorama map.
  auto generator = at::make_generator<at::CPUGeneratorImpl>(3);
  augment::MultiViewOptions options;
  options.view_size = 128;
  const auto views = augment::tiling_views(pano, options);
  const augment::Teacher scaled = [&](const at::Tensor& image, const camera::Camera& cam) {
    for (const auto& v : views) {
      if (at::equal(augment::extract_view(pano, wide.sample.image, v).image, image)) {
        return oracle(wide.scene, v.rotation,
                      std::exp(at::rand({1}, generator, at::kDouble).item<double>() - 0.5))(image,
                                                                                            cam);
      }
    }
    throw std::logic_error("unknown view");
  };
  const auto merged = augment::predict_wide_from_views(pano, wide.sample.image, scaled, options);
  io::write_image_png(out + "/a2p_multiview.png",
                      panels({geometry::colorize_depth(merged.distance, merged.mask),
                              geometry::colorize_depth(wide.sample.distance, wide.sample.mask)},
                             0));
  for (std::size_t i = 0; i < merged.view_scales.size(); ++i)
    std::cout << "view " << i << " scale " << merged.view_scales[i] << "\n";
  return 0;
}

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "augment_pictures: error: " << e.what() << "\n";
    return 1;
  }
}
