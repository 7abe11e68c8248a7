// A job's stored reference mesh: made once from the model, then read back on every later run.
#include "daemon/job_reference.hpp"

#include <sstream>
#include <string>

#include "daemon/client/rpc_error.hpp"
#include "daemon/client/sha256.hpp"
#include "geometry/ply_io.hpp"
#include "hal/utc_time.hpp"

namespace cmm::daemon {

namespace fs = std::filesystem;

nlohmann::json scan_report_json(const geometry::ScanReport& r) {
  nlohmann::json times = nlohmann::json::array();
  for (const geometry::ScanStageTime& t : r.times) times.push_back({{"stage", t.stage}, {"seconds", t.seconds}});
  return {{"points_in", r.points_in},
          {"outliers_removed", r.outliers_removed},
          {"points_kept", r.points_kept},
          {"points_sparse", r.points_sparse},
          {"triangles", r.triangles},
          {"bin_size_mm", r.bin_size_mm},
          {"bin_size_source", r.bin_size_source},
          {"noise_sigma_mm", r.noise_sigma_mm},
          {"outer_loops", r.outer_loops},
          {"hole_loops", r.hole_loops},
          {"creases", r.creases},
          {"crease_points", r.crease_points},
          {"components", r.components},
          {"times", times}};
}

namespace {

RpcError damaged(int job_id, const fs::path& file, const std::string& why) {
  return RpcError(rpc_code::model_error,
                  "job " + std::to_string(job_id) + "'s stored reference mesh " + file.string() + " " + why +
                      ": it is not the mesh the job was planned on; submit the job again",
                  {{"file", file.string()}, {"kind", "unreadable"}});
}

// The run after the first: the stored mesh, already in mm, checked against the digest taken when it
// was stored. Scan options no longer apply: it is a mesh.
JobReference stored_reference(JobStore& store, int job_id, const JobRequest& request,
                              const description::TravelBox& travel_box, const geometry::CancelCheck& cancel) {
  const fs::path mesh_file = store.path(job_id, JobFile::reference_mesh);
  nlohmann::json info = nlohmann::json::object();
  if (const std::optional<std::string> text = store.read(job_id, JobFile::reference_info)) {
    info = nlohmann::json::parse(*text, nullptr, false);
    if (!info.is_object()) throw damaged(job_id, mesh_file, "has a reference.json that is not a JSON object");
    const auto recorded = info.find("sha256");
    if (recorded == info.end() || !recorded->is_string()) throw damaged(job_id, mesh_file, "has no sha256 in reference.json");
    if (const std::string actual = sha256_hex_of_file(mesh_file); actual != recorded->get<std::string>())
      throw damaged(job_id, mesh_file, "hashes to " + actual + ", not the " + recorded->get<std::string>() +
                                           " reference.json recorded when it was stored");
  }
  // (Without reference.json, cmmd stopped between the two writes: the mesh was written whole, atomically.)
  JobRequest as_stored = request;
  as_stored.scale = 1;
  as_stored.tolerance_mm.reset();
  as_stored.bin_size_mm.reset();
  as_stored.adaptive = false;
  // A scan's mesh keeps its features as they were first taken (a scan's mesh is noisy by construction).
  const auto scan = info.find("scan");
  const bool from_scan = scan != info.end() && scan->is_object();
  ReferenceModel model = load_reference_model(mesh_file, as_stored, travel_box, cancel, from_scan);
  model.inputs.notes.push_back("planned on the job's stored reference mesh " + mesh_file.string() + ", made from " +
                               request.model + " when the job first planned (reference.json); the model file is not read again");
  info["planned_on"] = "stored_mesh";
  return {std::move(model), std::move(info)};
}

}  // namespace

JobReference job_reference(JobStore& store, int job_id, const ModelStore& models, const JobRequest& request,
                           const description::TravelBox& travel_box, const geometry::CancelCheck& cancel) {
  if (fs::exists(store.path(job_id, JobFile::reference_mesh)))
    return stored_reference(store, job_id, request, travel_box, cancel);

  const fs::path model_file = models.resolve(request.model);
  ReferenceModel model = load_reference_model(model_file, request, travel_box, cancel);
  // Binary PLY of float64: read back bit for bit, so the features and the plan's touch ids come out the same.
  std::ostringstream out(std::ios::binary);
  geometry::write_ply(out, model.mesh);
  const std::string bytes = out.str();
  Sha256 digest;
  digest.update(bytes);
  nlohmann::json info = {{"mesh", file_name(JobFile::reference_mesh)},
                         {"sha256", digest.hex_digest()},
                         {"model", request.model},
                         {"model_file", model_file.string()},
                         {"scale", request.scale},
                         {"vertices", model.mesh.vertices.rows()},
                         {"faces", model.mesh.faces.rows()},
                         {"scan", model.scan ? scan_report_json(*model.scan) : nlohmann::json(nullptr)},
                         {"time_utc", hal::utc_now()}};
  store.write(job_id, JobFile::reference_mesh, bytes);
  store.write(job_id, JobFile::reference_info, info.dump(1) + "\n");
  info["planned_on"] = "model";
  return {std::move(model), std::move(info)};
}

}  // namespace cmm::daemon
