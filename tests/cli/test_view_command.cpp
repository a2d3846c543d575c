// End to end: `omnipoint view` on a prediction of the bundled pinhole example made by the
// bundled model: the page, three.js, the API, the cloud (whole and subsampled) and the files
// over HTTP; the paths that leave the folder refused; bad folders and a taken port as one line;
// a rig frame (the layout `predict --rig` writes) as one fused cloud with its cameras placed by
// rig.json's poses, and bad rig frames as one line; and, where Chromium is installed, the page
// rendering the cloud and the rig frame in a real browser.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/ply.h"
#include "support/cli_run.h"
#include "support/glb_chunks.h"
#include "support/view_server.h"

namespace {

namespace fs = std::filesystem;
using omnipoint::test::CliRun;
using omnipoint::test::run_omnipoint;
using omnipoint::test::ViewServer;

class ViewCommand : public ::testing::Test {
 protected:
  // One prediction for the whole suite: DIR/out/pinhole/ from examples/images/pinhole.png
  // with its pinhole camera.
  static void SetUpTestSuite() {
    dir_ = new fs::path(omnipoint::test::fresh_process_dir("omnipoint_view"));
    const std::string examples = std::string(OMNIPOINT_SOURCE_DIR) + "/examples/images/";
    const CliRun run = run_omnipoint("predict " + examples + "pinhole.png --camera " + examples +
                                         "pinhole.txt --out " + (predictions() / "out").string(),
                                     *dir_ / "predict");
    ASSERT_EQ(run.status, 0) << run.err;
    points_ = omnipoint::io::read_ply((folder() / "points.ply").string()).points.size(0);
    // Beside it, a prediction still being written (a staging folder, io::StagedFolder): not
    // listed (ServesThePageThreeJsAndTheFolderList counts one).
    fs::copy(folder(), predictions() / "out" / ".pinhole.partial-Ab12cd",
             fs::copy_options::recursive);
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  static fs::path predictions() { return *dir_ / "predictions"; }
  static fs::path folder() { return predictions() / "out" / "pinhole"; }
  static fs::path scratch(const std::string& name) { return *dir_ / name; }

  static fs::path* dir_;
  static int64_t points_;
};
fs::path* ViewCommand::dir_ = nullptr;
int64_t ViewCommand::points_ = 0;

// A client that sends paths exactly as written (no encoding of its own).
httplib::Client client(const ViewServer& server) {
  httplib::Client http("127.0.0.1", server.port());
  http.set_url_encode(false);
  return http;
}

httplib::Result get(const ViewServer& server, const std::string& path) {
  return client(server).Get(path);
}

TEST_F(ViewCommand, ServesThePageThreeJsAndTheFolderList) {
  const ViewServer server(predictions().string(), scratch("serve"));
  EXPECT_EQ(server.url(), "http://127.0.0.1:" + std::to_string(server.port()) + "/");
  const auto page = get(server, "/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_EQ(page->get_header_value("Content-Type"), "text/html; charset=utf-8");
  EXPECT_NE(page->body.find(R"("three": "/three/build/three.module.js")"), std::string::npos);
  for (const std::string path :
       {"/view.js", "/three/build/three.module.js", "/three/build/three.core.js",
        "/three/examples/jsm/controls/OrbitControls.js",
        "/three/examples/jsm/loaders/GLTFLoader.js"}) {
    const auto script = get(server, path);
    ASSERT_TRUE(script) << path;
    EXPECT_EQ(script->status, 200) << path;
    EXPECT_EQ(script->get_header_value("Content-Type"), "text/javascript; charset=utf-8") << path;
    EXPECT_GT(script->body.size(), 1000u) << path;
  }
  EXPECT_EQ(get(server, "/view.css")->get_header_value("Content-Type"), "text/css; charset=utf-8");

  const auto list = get(server, "/api/predictions");
  ASSERT_TRUE(list);
  EXPECT_EQ(list->get_header_value("Content-Type"), "application/json");
  const nlohmann::json listed = nlohmann::json::parse(list->body);
  ASSERT_EQ(listed["predictions"].size(), 1u) << list->body;
  EXPECT_EQ(listed["predictions"][0]["name"], "out/pinhole");
  EXPECT_EQ(listed["predictions"][0]["points"].get<int64_t>(), points_);

  const auto detail = get(server, "/api/prediction?name=out/pinhole");
  ASSERT_TRUE(detail);
  const nlohmann::json described = nlohmann::json::parse(detail->body);
  EXPECT_EQ(described["camera_class"], "perspective");
  EXPECT_EQ(described["record"]["valid_pixels"].get<int64_t>(), points_);
  const auto& files = described["files"];
  for (const std::string file : {"camera.json", "image.png", "mask.png", "points.glb"})
    EXPECT_NE(std::find(files.begin(), files.end(), file), files.end()) << file;
  // The frustum's rays through the image border (4 sides of 8 steps): unit, in front, the first
  // through the top-left corner (0, 0) of PINHOLE 320 240 260 260 160 120.
  ASSERT_EQ(described["frustum_rays"].size(), 32u);
  for (const auto& ray : described["frustum_rays"]) {
    EXPECT_NEAR(std::hypot(ray[0].get<double>(), ray[1].get<double>(), ray[2].get<double>()), 1,
                1e-9);
    EXPECT_GT(ray[2].get<double>(), 0);
  }
  const auto& corner = described["frustum_rays"][0];
  EXPECT_NEAR(corner[0].get<double>() / corner[2].get<double>(), -160.0 / 260, 1e-9);
  EXPECT_NEAR(corner[1].get<double>() / corner[2].get<double>(), -120.0 / 260, 1e-9);
}

TEST_F(ViewCommand, ServesTheCloudAndTheFilesReadOnly) {
  const ViewServer server(predictions().string(), scratch("cloud"));
  const auto cloud = get(server, "/cloud?name=out/pinhole");
  ASSERT_TRUE(cloud);
  EXPECT_EQ(cloud->status, 200);
  EXPECT_EQ(cloud->get_header_value("Content-Type"), "model/gltf-binary");
  // Under the budget: points.glb itself, byte for byte.
  EXPECT_EQ(cloud->body, omnipoint::test::slurp(folder() / "points.glb"));
  EXPECT_EQ(cloud->get_header_value("X-Omnipoint-Points-Total"), std::to_string(points_));
  EXPECT_EQ(cloud->get_header_value("X-Omnipoint-Points-Shown"), std::to_string(points_));

  const auto record = get(server, "/files/out/pinhole/camera.json");
  ASSERT_TRUE(record);
  EXPECT_EQ(record->status, 200);
  EXPECT_EQ(record->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(record->body, omnipoint::test::slurp(folder() / "camera.json"));
  EXPECT_EQ(get(server, "/files/out/pinhole/mask.png")->get_header_value("Content-Type"),
            "image/png");
  // depth.png coloured: an 8-bit RGB PNG of the map's size, black where the map is 0.
  const auto colourised = get(server, "/colourised/out/pinhole/depth.png");
  ASSERT_TRUE(colourised);
  EXPECT_EQ(colourised->status, 200);
  EXPECT_EQ(colourised->get_header_value("Content-Type"), "image/png");
  const fs::path picture = scratch("depth_colour.png");
  std::ofstream(picture, std::ios::binary) << colourised->body;
  const at::Tensor colours = omnipoint::io::read_image_values(picture.string());
  const at::Tensor depth = omnipoint::io::read_image_values((folder() / "depth.png").string());
  ASSERT_EQ(colours.sizes(), (at::IntArrayRef{depth.size(0), depth.size(1), 3}));
  EXPECT_TRUE(at::equal(colours.amax(-1) > 0, depth > 0));

  const auto head = client(server).Head("/files/out/pinhole/camera.json");
  ASSERT_TRUE(head);
  EXPECT_EQ(head->status, 200);
  EXPECT_TRUE(head->body.empty());
  for (const auto& response :
       {client(server).Post("/files/out/pinhole/camera.json", "x", "text/plain"),
        client(server).Put("/files/out/pinhole/camera.json", "x", "text/plain"),
        client(server).Delete("/files/out/pinhole/camera.json")}) {
    ASSERT_TRUE(response);
    EXPECT_EQ(response->status, 405);
    EXPECT_EQ(response->get_header_value("Allow"), "GET, HEAD");
  }
  EXPECT_TRUE(fs::is_regular_file(folder() / "camera.json"));
  EXPECT_EQ(get(server, "/files/out/pinhole/no_such_file.png")->status, 404);
  EXPECT_EQ(get(server, "/cloud?name=out/no_such_folder")->status, 404);
  EXPECT_EQ(get(server, "/cloud")->status, 400);
  EXPECT_EQ(get(server, "/no/such/route")->status, 404);
}

TEST_F(ViewCommand, SubsamplesToMaxPoints) {
  const int64_t budget = 1000;
  ASSERT_GT(points_, 3 * budget);
  const ViewServer server(predictions().string() + " --max-points " + std::to_string(budget),
                          scratch("subsample"));
  const auto cloud = get(server, "/cloud?name=out/pinhole");
  ASSERT_TRUE(cloud);
  EXPECT_EQ(cloud->status, 200);
  EXPECT_EQ(cloud->get_header_value("X-Omnipoint-Points-Total"), std::to_string(points_));
  EXPECT_EQ(cloud->get_header_value("X-Omnipoint-Points-Shown"), std::to_string(budget));
  EXPECT_EQ(nlohmann::json::parse(get(server, "/api/predictions")->body)["max_points"], budget);
  const omnipoint::test::GlbChunks glb = omnipoint::test::parse_glb(cloud->body);
  ASSERT_EQ(glb.gltf["accessors"][0]["count"].get<int64_t>(), budget);
  // Point i is the PLY's point floor(i * total / budget), in the GLB's frame (x, -y, -z).
  const at::Tensor ply = omnipoint::io::read_ply((folder() / "points.ply").string()).points;
  for (const int64_t i : {int64_t{0}, int64_t{1}, budget / 2, budget - 1}) {
    float position[3];
    std::memcpy(position, glb.bin.data() + 12 * i, 12);
    const at::Tensor expected = ply[i * points_ / budget];
    EXPECT_FLOAT_EQ(position[0], expected[0].item<float>()) << i;
    EXPECT_FLOAT_EQ(position[1], -expected[1].item<float>()) << i;
    EXPECT_FLOAT_EQ(position[2], -expected[2].item<float>()) << i;
  }
}

TEST_F(ViewCommand, RefusesPathsOutsideTheFolder) {
  const fs::path secret = scratch("secret.txt");
  std::ofstream(secret) << "not to be served\n";
  fs::create_symlink(secret, folder() / "link_out.txt");
  fs::create_directory_symlink(*dir_, folder() / "dir_out");
  std::ofstream(folder() / "inside.txt") << "inside\n";
  fs::create_symlink(folder() / "inside.txt", folder() / "link_in.txt");
  const ViewServer server(predictions().string(), scratch("traversal"));
  for (const std::string path :
       {"/files/../secret.txt", "/files/out/../../secret.txt", "/files/%2e%2e/secret.txt",
        "/files/out/pinhole/%2e%2e%2f%2e%2e%2f%2e%2e%2fsecret.txt", "/files/%2E%2E%2Fsecret.txt",
        "/files/out/pinhole/..%2f..%2f..%2fsecret.txt", "/files/out/pinhole/link_out.txt",
        "/files/out/pinhole/dir_out/secret.txt", "/files/%2fetc%2fpasswd",
        "/three/..%2f..%2f..%2f..%2fetc/passwd", "/three/../package.json",
        "/api/prediction?name=..", "/api/prediction?name=out%2f..%2f..", "/cloud?name=%2e%2e",
        "/cloud?name=out/pinhole/dir_out", "/colourised/%2e%2e%2fsecret.txt",
        "/colourised/out/pinhole/link_out.txt"}) {
    const auto response = get(server, path);
    ASSERT_TRUE(response) << path;
    EXPECT_TRUE(response->status == 403 || response->status == 404)
        << path << ": " << response->status;
    EXPECT_EQ(response->body.find("not to be served"), std::string::npos) << path;
  }
  EXPECT_EQ(get(server, "/files/out/pinhole/link_out.txt")->status, 403);
  // A symlink that stays inside is followed.
  EXPECT_EQ(get(server, "/files/out/pinhole/link_in.txt")->body, "inside\n");
  fs::remove(folder() / "link_out.txt");
  fs::remove(folder() / "dir_out");
  fs::remove(folder() / "link_in.txt");
  fs::remove(folder() / "inside.txt");
}

// A failed start: non-zero exit and exactly one line, an error naming `mention`.
void expect_refusal(const CliRun& run, const std::string& mention) {
  EXPECT_NE(run.status, 0);
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  EXPECT_EQ(run.err.rfind("omnipoint: error: view: ", 0), 0u) << run.err;
  EXPECT_NE(run.err.find(mention), std::string::npos) << run.err;
}

TEST_F(ViewCommand, BadFoldersAndATakenPortAreOneLine) {
  const fs::path missing = scratch("missing");
  expect_refusal(run_omnipoint("view " + missing.string(), scratch("bad")), "no such folder");
  const fs::path empty = scratch("empty");
  fs::create_directories(empty / "sub");
  expect_refusal(run_omnipoint("view " + empty.string(), scratch("bad")),
                 "holds no prediction folder");
  const ViewServer first(predictions().string(), scratch("first"));
  expect_refusal(
      run_omnipoint("view " + predictions().string() + " --port " + std::to_string(first.port()),
                    scratch("bad")),
      "the port is in use");
}

TEST_F(ViewCommand, WarnsWhenListeningBeyondThisMachine) {
  const ViewServer server(predictions().string() + " --host 0.0.0.0", scratch("wide"));
  EXPECT_EQ(server.err().rfind("omnipoint: warning: view: listening on 0.0.0.0", 0), 0u)
      << server.err();
  EXPECT_EQ(get(server, "/")->status, 200);
}

// A rig frame as `predict --rig` writes it (predict/rig_predict_job.h), in a vehicle's body frame
// (x forward, y left, z up): rig.json, fused.ply of `points` points, and a prediction folder per
// camera: "front" and "left" copies of the pinhole prediction, "pano" an equirectangular
// camera.json alone (too wide for a frustum).
nlohmann::json write_rig_frame(const fs::path& frame, const fs::path& pinhole, int64_t points) {
  fs::create_directories(frame);
  for (const std::string camera : {"front", "left"})
    fs::copy(pinhole, frame / camera, fs::copy_options::recursive);
  fs::create_directories(frame / "pano");
  std::ofstream(frame / "pano" / "camera.json")
      << omnipoint::camera::make_camera("EQUIRECTANGULAR", 64, 32, {}).to_json();
  const double c = std::cos(0.7), s = std::sin(0.7);
  const auto camera = [](const std::vector<std::vector<double>>& pose, double scale,
                         const std::string& source) {
    return nlohmann::json{{"scale", scale},
                          {"scale_source", source},
                          {"disagreement", scale / 1.05 - 1},
                          {"applied_scale", source == "lidar" ? scale : 1.05},
                          {"sparse_samples", source == "lidar" ? 812 : 0},
                          {"image", "frames/000000/camera.png"},
                          {"body_from_camera", pose}};
  };
  const nlohmann::json report = {
      {"frame", "vehicle"},
      {"rig_scale", 1.05},
      {"overlap_residual", nullptr},
      {"scale_rule", "median of the LiDAR-aligned cameras' scales"},
      {"lidar", "frames/000000/lidar.bin"},
      {"missing_cameras", nlohmann::json::array()},
      {"fused_points", points},
      {"cameras",
       {{"front",
         camera({{0, 0, 1, 1.5}, {-1, 0, 0, 0.0123456789}, {0, -1, 0, 1.2}}, 1.05, "lidar")},
        {"left", camera({{1, 0, 0, 0.5}, {0, 0, 1, 0.9}, {0, -1, 0, 1.0}}, 0.93, "network")},
        {"pano", camera({{s, 0, c, 0.25}, {-c, 0, s, -0.1}, {0, -1, 0, 1.9}}, 1.2, "network")}}}};
  std::ofstream(frame / "rig.json") << report.dump(2);
  const at::Tensor cloud = at::rand({points, 3}, at::kFloat) * 20 - 10;
  const at::Tensor colours = at::randint(0, 256, {points, 3}, at::kByte);
  omnipoint::io::write_ply((frame / "fused.ply").string(), cloud, colours);
  return report;
}

TEST_F(ViewCommand, RigFrameIsOneCloudWithEveryCameraPlaced) {
  const fs::path frame = scratch("rig_one") / "000000";
  const int64_t points = 600;
  const nlohmann::json report = write_rig_frame(frame, folder(), points);
  const ViewServer server(frame.string(), scratch("rig_one_view"));

  // The frame itself (".") and each camera's own prediction folder.
  const nlohmann::json listed = nlohmann::json::parse(get(server, "/api/predictions")->body);
  ASSERT_EQ(listed["predictions"].size(), 4u) << listed;
  EXPECT_EQ(listed["predictions"][0],
            (nlohmann::json{{"name", "."}, {"kind", "rig"}, {"points", points}}));
  EXPECT_EQ(listed["predictions"][1]["name"], "front");
  EXPECT_EQ(listed["predictions"][1]["kind"], "prediction");
  EXPECT_EQ(listed["predictions"][3]["name"], "pano");

  const auto detail = get(server, "/api/prediction?name=.");
  ASSERT_TRUE(detail);
  ASSERT_EQ(detail->status, 200) << detail->body;
  const nlohmann::json described = nlohmann::json::parse(detail->body);
  EXPECT_EQ(described["kind"], "rig");
  EXPECT_EQ(described["record"], report);
  // The body frame's up: every camera's -y is the body's +z.
  ASSERT_EQ(described["up"].size(), 3u);
  EXPECT_NEAR(described["up"][0].get<double>(), 0, 1e-12);
  EXPECT_NEAR(described["up"][1].get<double>(), 0, 1e-12);
  EXPECT_NEAR(described["up"][2].get<double>(), 1, 1e-12);
  const auto& cameras = described["cameras"];
  ASSERT_EQ(cameras.size(), 3u) << cameras;
  const std::vector<std::string> names = {"front", "left", "pano"};
  for (size_t i = 0; i < names.size(); ++i) {
    SCOPED_TRACE(names[i]);
    const auto& camera = cameras[i];
    const auto& reported = report["cameras"][names[i]];
    EXPECT_EQ(camera["name"], names[i]);
    EXPECT_EQ(camera["folder"], names[i]);
    EXPECT_EQ(camera["body_from_camera"], reported["body_from_camera"]);  // exact
    EXPECT_EQ(camera["scale"], reported["scale"]);
    EXPECT_EQ(camera["scale_source"], reported["scale_source"]);
    EXPECT_EQ(camera["disagreement"], reported["disagreement"]);
    EXPECT_FALSE(camera.contains("camera_error")) << camera["camera_error"];
  }
  EXPECT_EQ(cameras[0]["camera_class"], "perspective");
  EXPECT_EQ(cameras[0]["frustum_rays"].size(), 32u);
  EXPECT_EQ(cameras[0]["has_image"], true);
  EXPECT_EQ(cameras[2]["camera_class"], "panorama");
  EXPECT_TRUE(cameras[2]["frustum_rays"].is_null());  // centre and axes instead
  EXPECT_EQ(cameras[2]["has_image"], false);

  // One cloud: fused.ply's points in the GLB's frame (x, -y, -z).
  const auto cloud = get(server, "/cloud?name=.");
  ASSERT_TRUE(cloud);
  ASSERT_EQ(cloud->status, 200);
  EXPECT_EQ(cloud->get_header_value("X-Omnipoint-Points-Total"), std::to_string(points));
  EXPECT_EQ(cloud->get_header_value("X-Omnipoint-Points-Shown"), std::to_string(points));
  const omnipoint::test::GlbChunks glb = omnipoint::test::parse_glb(cloud->body);
  ASSERT_EQ(glb.gltf["accessors"][0]["count"].get<int64_t>(), points);
  const at::Tensor ply = omnipoint::io::read_ply((frame / "fused.ply").string()).points;
  for (const int64_t i : {int64_t{0}, points - 1}) {
    float position[3];
    std::memcpy(position, glb.bin.data() + 12 * i, 12);
    EXPECT_FLOAT_EQ(position[0], ply[i][0].item<float>()) << i;
    EXPECT_FLOAT_EQ(position[1], -ply[i][1].item<float>()) << i;
    EXPECT_FLOAT_EQ(position[2], -ply[i][2].item<float>()) << i;
  }
  // A camera's own folder is still a prediction of its own.
  EXPECT_EQ(nlohmann::json::parse(get(server, "/api/prediction?name=front")->body)["kind"],
            "prediction");

  const ViewServer budget(frame.string() + " --max-points 100", scratch("rig_one_budget"));
  const auto fewer = get(budget, "/cloud?name=.");
  ASSERT_TRUE(fewer);
  EXPECT_EQ(fewer->get_header_value("X-Omnipoint-Points-Total"), std::to_string(points));
  EXPECT_EQ(fewer->get_header_value("X-Omnipoint-Points-Shown"), "100");
}

TEST_F(ViewCommand, RigOutputFolderListsEveryFrame) {
  const fs::path out = scratch("rig_frames");
  write_rig_frame(out / "000000", folder(), 300);
  write_rig_frame(out / "000001", folder(), 200);
  const ViewServer server(out.string(), scratch("rig_frames_view"));
  EXPECT_NE(omnipoint::test::slurp(scratch("rig_frames_view") / "view_stdout")
                .find("serving 2 rig frame(s) and 6 prediction(s) of "),
            std::string::npos);
  const nlohmann::json listed = nlohmann::json::parse(get(server, "/api/predictions")->body);
  std::vector<std::string> frames;
  for (const auto& entry : listed["predictions"])
    if (entry["kind"] == "rig") frames.push_back(entry["name"]);
  EXPECT_EQ(frames, (std::vector<std::string>{"000000", "000001"})) << listed;
  const nlohmann::json described =
      nlohmann::json::parse(get(server, "/api/prediction?name=000001")->body);
  EXPECT_EQ(described["cameras"][1]["folder"], "000001/left");
  EXPECT_EQ(get(server, "/cloud?name=000001")->get_header_value("X-Omnipoint-Points-Total"), "200");
  EXPECT_EQ(nlohmann::json::parse(get(server, "/api/prediction?name=000001/left")->body)["kind"],
            "prediction");

  // A frame broken while it is served: still listed (no point count), its detail an error.
  std::ofstream(out / "000001" / "rig.json") << "{";
  const nlohmann::json relisted = nlohmann::json::parse(get(server, "/api/predictions")->body);
  EXPECT_EQ(relisted["predictions"].size(), listed["predictions"].size());
  for (const auto& entry : relisted["predictions"]) {
    if (entry["name"] == "000001") {
      EXPECT_TRUE(entry["points"].is_null()) << entry;
    }
  }
  const auto broken = get(server, "/api/prediction?name=000001");
  ASSERT_TRUE(broken);
  EXPECT_EQ(broken->status, 500);
  EXPECT_NE(broken->body.find("000001/rig.json: not JSON"), std::string::npos) << broken->body;
}

TEST_F(ViewCommand, BadRigFramesAreOneLine) {
  const auto broken = [&](const std::string& name) {
    const fs::path frame = scratch("rig_bad") / name;
    write_rig_frame(frame, folder(), 50);
    return frame;
  };
  const fs::path not_json = broken("not_json");
  std::ofstream(not_json / "rig.json") << "{\"cameras\": {";
  expect_refusal(run_omnipoint("view " + not_json.string(), scratch("bad")), "rig.json: not JSON");

  const fs::path no_cloud = broken("no_cloud");
  fs::remove(no_cloud / "fused.ply");
  expect_refusal(run_omnipoint("view " + no_cloud.string(), scratch("bad")), "no fused.ply");

  const fs::path bad_pose = broken("bad_pose");
  nlohmann::json report = nlohmann::json::parse(omnipoint::test::slurp(bad_pose / "rig.json"));
  report["cameras"]["left"]["body_from_camera"] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  std::ofstream(bad_pose / "rig.json") << report.dump();
  expect_refusal(run_omnipoint("view " + bad_pose.string(), scratch("bad")),
                 "rig.json: cameras.left.body_from_camera: expected 3 rows of 4 numbers");

  const fs::path no_cameras = broken("no_cameras");
  std::ofstream(no_cameras / "rig.json") << R"({"frame": "body", "cameras": {}})";
  expect_refusal(run_omnipoint("view " + no_cameras.string(), scratch("bad")), "cameras:");

  // One bad frame among good ones refuses the whole folder, naming it.
  const fs::path out = scratch("rig_bad_among");
  write_rig_frame(out / "000000", folder(), 50);
  write_rig_frame(out / "000001", folder(), 50);
  fs::remove(out / "000001" / "fused.ply");
  expect_refusal(run_omnipoint("view " + out.string(), scratch("bad")),
                 (out / "000001").string() + ": no fused.ply");
}

// Headless Chromium with WebGL on SwiftShader (software); DIR/pinhole's page is captured once
// it is done loading (virtual time runs ahead while the page waits on nothing).
std::string chromium() {
  for (const char* candidate : {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (fs::exists(candidate)) return candidate;
  return "";
}

std::string chromium_command(const std::string& output_flag, const std::string& url) {
  return chromium() +
         " --headless=new --no-sandbox --disable-gpu-sandbox --use-gl=angle "
         "--use-angle=swiftshader --enable-unsafe-swiftshader --no-first-run "
         "--disable-extensions --hide-scrollbars --window-size=1024,768 "
         "--virtual-time-budget=30000 " +
         output_flag + " '" + url + "'";
}

// The share of the pixels of `region` (x0, y0, x1, y1) that differ from the page's background.
double drawn_share(const at::Tensor& screenshot, int64_t x0, int64_t y0, int64_t x1, int64_t y1) {
  const at::Tensor region = screenshot.slice(0, y0, y1).slice(1, x0, x1) * 255;
  const at::Tensor background = at::tensor({0x1d, 0x20, 0x26}, at::kFloat);
  return ((region - background).abs().amax(-1) > 24).to(at::kFloat).mean().item<double>();
}

TEST_F(ViewCommand, ChromiumRendersTheCloud) {
  if (chromium().empty())
    GTEST_SKIP() << "Chromium is not installed (/usr/bin/chromium; scripts/install_deps.sh "
                    "--tests installs it)";
  // Beside the prediction, a folder with no cloud: its page must stay blank where the cloud goes.
  const fs::path blank = predictions() / "blank";
  fs::create_directories(blank);
  fs::copy_file(folder() / "camera.json", blank / "camera.json");
  const ViewServer server(predictions().string(), scratch("browser"));
  const fs::path browser = scratch("chromium");
  fs::create_directories(browser);
  const std::string profile = " --user-data-dir=" + (browser / "profile").string();

  const CliRun dom = omnipoint::test::run_command(
      chromium_command("--dump-dom" + profile, server.url() + "#out/pinhole"), browser);
  EXPECT_NE(dom.out.find(R"(data-rendered="out/pinhole")"), std::string::npos)
      << dom.out << dom.err;
  std::string shown = std::to_string(points_);  // as the page writes it: 76,800
  for (auto comma = static_cast<std::ptrdiff_t>(shown.size()) - 3; comma > 0; comma -= 3)
    shown.insert(static_cast<size_t>(comma), ",");
  EXPECT_NE(dom.out.find("showing " + shown + " points<"), std::string::npos) << dom.out;

  const auto screenshot = [&](const std::string& name) {
    const fs::path png = browser / (name + ".png");
    const CliRun shot = omnipoint::test::run_command(
        chromium_command("--screenshot=" + png.string() + profile,
                         server.url() + "#" + (name == "blank" ? "blank" : "out/pinhole")),
        browser);
    EXPECT_TRUE(fs::is_regular_file(png)) << shot.err;
    return fs::is_regular_file(png) ? omnipoint::io::read_image(png.string()) : at::Tensor();
  };
  const at::Tensor cloud = screenshot("cloud"), empty = screenshot("blank");
  ASSERT_TRUE(cloud.defined() && empty.defined());
  ASSERT_EQ(cloud.sizes(), (at::IntArrayRef{768, 1024, 3}));
  // The middle of the 3D view (right of the folder list, below the controls).
  const double drawn = drawn_share(cloud, 320, 160, 900, 440);
  const double undrawn = drawn_share(empty, 320, 160, 900, 440);
  EXPECT_GT(drawn, 0.2) << "the cloud is missing from the screenshot";
  EXPECT_LT(undrawn, 0.01) << "a folder without a cloud shows something";
  fs::remove_all(blank);
}

// The rig frame's page: the fused cloud and its three cameras (the page's status line says so
// once the first frame is drawn; a script error would leave "error: ..." there instead).
TEST_F(ViewCommand, ChromiumRendersARigFrame) {
  if (chromium().empty())
    GTEST_SKIP() << "Chromium is not installed (/usr/bin/chromium; scripts/install_deps.sh "
                    "--tests installs it)";
  const fs::path out = scratch("rig_browser");
  write_rig_frame(out / "000000", folder(), 2000);
  const ViewServer server(out.string(), scratch("rig_browser_view"));
  const fs::path browser = scratch("rig_chromium");
  fs::create_directories(browser);
  const std::string profile = " --user-data-dir=" + (browser / "profile").string();
  const CliRun dom = omnipoint::test::run_command(
      chromium_command("--dump-dom" + profile, server.url() + "#000000"), browser);
  EXPECT_NE(dom.out.find(R"(data-rendered="000000")"), std::string::npos) << dom.out << dom.err;
  EXPECT_NE(dom.out.find("showing 2,000 points and 3 cameras in the body frame (vehicle)<"),
            std::string::npos)
      << dom.out;
  // The cameras' images link to their own predictions; the summary lists every camera's scale.
  EXPECT_NE(dom.out.find(R"(href="#000000%2Ffront")"), std::string::npos) << dom.out;
  EXPECT_NE(dom.out.find("scale 0.9300 (network), disagreement -11.43 %, shown at the rig "
                         "scale 1.0500"),
            std::string::npos)
      << dom.out;
}

}  // namespace
