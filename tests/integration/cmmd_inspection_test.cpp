// Verdicts through the real cmmd: a job on the in-process simulator held against the sample part's
// nominal (a CAD export in the scan's frame), then the same job with one tolerance changed so that a
// hole's diameter fails: the verdict must say so in result.json, the CSV, the HTML report and the QIF
// file (which validates against the QIF 3.0 schema), and in the job record. And an honest verdict over
// Modbus (the real cmm-sim): a job whose features it was asked for went unmeasured is incomplete
// everywhere, and the same job with those features left out on purpose passes, counting them apart.
// A nominal that is no mesh, or no model at all, is refused at its own field by plan.preview and
// job.submit alike, before any work.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "rpc_exchange.hpp"
#include "web_client.hpp"
#include "daemon/client/model_upload.hpp"
#include "daemon/client/rpc_error.hpp"
#include "geometry/mesh_io.hpp"
#include "geometry/xyz_io.hpp"
#include "tests/daemon/fresh_folder.hpp"
#include "tests/tools/run_command.hpp"

namespace cmm {
namespace {

using nlohmann::json;
using testing::CmmdInstance;

std::filesystem::path sample_nominal(const std::filesystem::path& folder) {
  testing::sample_scan(folder);  // writes sim.json
  const std::filesystem::path nominal = folder / "nominal.stl";
  const auto r = cmm::test::run_command(std::string(CMMD_BINARY_DIR "/sim/cmm-scan") + " --sim-config " +
                                        (folder / "sim.json").string() + " --nominal " + nominal.string());
  if (r.exit_code != 0) throw std::runtime_error("cmm-scan --nominal failed: " + r.output);
  return nominal;
}

// The row of `id` in a CSV table, as cells (no quoted commas in these rows' leading cells).
std::map<std::string, std::string> csv_row(const std::string& csv, int id) {
  std::istringstream lines(csv);
  std::string header, line;
  std::getline(lines, header);
  const auto cells = [](const std::string& text) {
    std::vector<std::string> out;
    std::stringstream s(text);
    for (std::string cell; std::getline(s, cell, ',');) out.push_back(cell);
    return out;
  };
  const std::vector<std::string> names = cells(header);
  while (std::getline(lines, line)) {
    const std::vector<std::string> values = cells(line);
    if (values.empty() || values[0] != std::to_string(id)) continue;
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < names.size() && i < values.size(); ++i) row[names[i]] = values[i];
    return row;
  }
  return {};
}

void expect_valid_qif(const std::string& qif, const std::filesystem::path& file) {
  std::ofstream(file) << qif;
  const auto r = cmm::test::run_command("xmllint --nonet --noout --schema " CMMD_TEST_DATA_DIR
                                        "/qif3/QIFApplications/QIFDocument.xsd " + file.string() + " 2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST(CmmdInspection, ATightenedHoleToleranceFailsInTheJsonCsvReportAndQif) {
  const auto dir = daemon::fresh_folder("inspection");
  CmmdInstance cmmd(dir / "cmmd", testing::sample_sim_block());
  cmmd.start();
  daemon::RpcClient client = cmmd.client();
  const std::string nominal = daemon::upload_model(client, sample_nominal(dir / "scan"), 256 * 1024);
  const json tolerances = {{"edge_profile_mm", 0.05}, {"hole_diameter_mm", {-0.02, 0.02}}, {"hole_position_mm", 0.05}};
  const json request = {{"spacing_mm", 8},
                        {"registration", testing::sample_measure_plate(dir / "scan")},
                        {"nominal", {{"model", nominal}, {"placement", "given"}}},
                        {"tolerances", tolerances}};

  const int first = testing::submit_job(client, testing::sample_scan(dir / "scan"), request);
  const json record = testing::wait_for_job(client, first, {"done", "failed"}, 300);
  ASSERT_EQ(record.at("state"), "done") << record.dump();
  const json result = client.call("job.result", {{"job", first}});
  const json& inspection = result.at("inspection");
  ASSERT_TRUE(inspection.is_object()) << result.at("notes").dump();
  EXPECT_EQ(inspection.at("nominal").at("method"), "given");
  EXPECT_EQ(record.at("verdict").at("verdict"), inspection.at("verdict"));
  // On the simulator's part, measured to a few µm against its own CAD export, nothing fails.
  EXPECT_EQ(inspection.at("counts").at("edge_points").at("fail"), 0) << inspection.dump();
  EXPECT_EQ(inspection.at("counts").at("holes").at("fail"), 0) << inspection.dump();
  EXPECT_GT(inspection.at("counts").at("edge_points").at("pass").get<int>(), 10) << inspection.dump();
  int hole = -1;
  for (const json& h : result.at("holes"))
    if (h.at("inspection").is_object() && h["inspection"].at("diameter").at("verdict") == "pass") {
      hole = h.at("id").get<int>();
      EXPECT_LT(std::abs(h["inspection"]["diameter"]["deviation_mm"].get<double>()), 0.01) << h.dump();
      break;
    }
  ASSERT_GE(hole, 0) << "no hole passed its diameter: " << result.at("holes").dump();
  expect_valid_qif(client.call("job.result", {{"job", first}, {"format", "qif"}}).at("qif"), dir / "first.qif");

  // The same job with that hole's diameter required 0.5 to 1 mm larger than nominal: it must fail.
  json tightened = request;
  tightened["tolerances"]["holes"] = {{std::to_string(hole), {{"diameter_mm", {0.5, 1.0}}}}};
  const int second = testing::submit_job(client, testing::sample_scan(dir / "scan"), tightened);
  const json record2 = testing::wait_for_job(client, second, {"done", "failed"}, 300);
  ASSERT_EQ(record2.at("state"), "done") << record2.dump();
  EXPECT_EQ(record2.at("verdict").at("verdict"), "fail") << record2.dump();
  EXPECT_NE(record2.at("reason").get<std::string>().find("verdict fail"), std::string::npos) << record2.dump();

  const json result2 = client.call("job.result", {{"job", second}});
  EXPECT_EQ(result2.at("inspection").at("verdict"), "fail");
  const json& failing = result2.at("holes").at(static_cast<std::size_t>(hole)).at("inspection");
  EXPECT_EQ(failing.at("diameter").at("verdict"), "fail") << failing.dump();
  EXPECT_EQ(failing.at("diameter").at("tolerance_mm"), json({0.5, 1.0}));
  EXPECT_EQ(failing.at("verdict"), "fail");

  const json csv = client.call("job.result", {{"job", second}, {"format", "csv"}});
  const auto row = csv_row(csv.at("holes_csv").get<std::string>(), hole);
  ASSERT_FALSE(row.empty()) << csv.at("holes_csv");
  EXPECT_EQ(row.at("diameter_verdict"), "fail");
  EXPECT_EQ(row.at("verdict"), "fail");
  EXPECT_EQ(row.at("diameter_lower_mm"), "0.500000");

  const std::string html = client.call("job.report", {{"job", second}}).at("html");
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(html.find("class=\"verdict v-fail\""), std::string::npos) << "the report shows no failing job verdict";
  const std::string qif = client.call("job.result", {{"job", second}, {"format", "qif"}}).at("qif");
  EXPECT_NE(qif.find("<CharacteristicStatusEnum>FAIL</CharacteristicStatusEnum>"), std::string::npos);
  EXPECT_NE(qif.find("<InspectionStatusEnum>FAIL</InspectionStatusEnum>"), std::string::npos);
  expect_valid_qif(qif, dir / "second.qif");
}

// A job on the sample scan run to its end: its id, record and result; std::runtime_error unless done.
struct DoneJob {
  int id = 0;
  json record, result;
};
DoneJob run_to_done(daemon::RpcClient& client, const std::filesystem::path& scan_folder, const json& request) {
  DoneJob job;
  job.id = testing::submit_job(client, testing::sample_scan(scan_folder), request);
  job.record = testing::wait_for_job(client, job.id, {"done", "failed"}, 300);
  if (job.record.at("state") != "done") throw std::runtime_error("job not done: " + job.record.dump());
  job.result = client.call("job.result", {{"job", job.id}});
  return job;
}

// The ids of the features (edge_points or holes) whose inspection is `verdict`.
std::vector<int> ids_judged(const json& result, const char* kind, const std::string& verdict) {
  std::vector<int> ids;
  for (const json& f : result.at(kind))
    if (f.at("inspection").at("verdict") == verdict) ids.push_back(f.at("id").get<int>());
  return ids;
}

// A counter's value in cmmd's /metrics text, e.g. `cmmd_job_verdicts_total{verdict="pass"}`.
long long metric(int http_port, const std::string& sample) {
  const std::string text = testing::http_request(http_port, "GET", "/metrics").body;
  const std::size_t at = text.find("\n" + sample + " ");
  return at == std::string::npos ? -1 : std::stoll(text.substr(at + sample.size() + 2));
}

TEST(CmmdInspection, UnmeasuredFeaturesMakeTheJobIncompleteLeftOutOnPurposeItPassesOverModbus) {
  const auto dir = daemon::fresh_folder("inspection-honest");
  testing::sample_scan(dir / "scan");
  testing::SimulatorProcess sim(dir / "scan" / "sim.json", 100);
  CmmdInstance cmmd(dir / "cmmd", testing::modbus_block(sim.port));
  cmmd.start();
  daemon::RpcClient client = cmmd.client();
  client.call("machine.home", json::object(), 120);
  client.call("machine.qualify", json::object(), 300);  // no touch on a tip never qualified
  const std::string nominal = daemon::upload_model(client, sample_nominal(dir / "scan"), 256 * 1024);
  // Tolerances wide against the simulator's µm, so that only coverage can keep the job from passing.
  const json request = {{"spacing_mm", 8},
                        {"registration", testing::sample_measure_plate(dir / "scan")},
                        {"nominal", {{"model", nominal}, {"placement", "given"}}},
                        {"tolerances", {{"edge_profile_mm", 0.1}, {"hole_diameter_mm", {-0.05, 0.05}}, {"hole_position_mm", 0.1}}}};

  // Every feature asked for (the default): the edges standing on the plate cannot be probed.
  const DoneJob first = run_to_done(client, dir / "scan", request);
  const int asked = first.id;
  const json& record = first.record;
  const json& result = first.result;
  const json& inspection = result.at("inspection");
  ASSERT_TRUE(inspection.is_object()) << result.at("notes").dump();
  const json& counts = inspection.at("counts");
  const int unmeasured_edges = counts.at("edge_points").at("not_measured").get<int>();
  const int unmeasured_holes = counts.at("holes").at("not_measured").get<int>();
  ASSERT_GT(unmeasured_edges, 0) << "the sample part has edges no probe reaches: " << counts.dump();
  EXPECT_EQ(counts.at("edge_points").at("fail"), 0) << counts.dump();
  EXPECT_GT(counts.at("edge_points").at("pass").get<int>(), 10) << counts.dump();
  EXPECT_EQ(counts.at("edge_points").at("excluded"), 0);
  EXPECT_EQ(inspection.at("verdict"), "incomplete") << "a part mostly measured and passing is not a pass";
  EXPECT_EQ(record.at("verdict").at("verdict"), "incomplete");
  EXPECT_EQ(record.at("verdict").at("coverage"), inspection.at("coverage"));
  EXPECT_NE(inspection.at("coverage").get<std::string>().find(std::to_string(unmeasured_edges) + " not measured"),
            std::string::npos) << inspection.at("coverage");
  EXPECT_NE(record.at("reason").get<std::string>().find("verdict incomplete"), std::string::npos) << record.dump();
  const std::vector<int> unmeasured = ids_judged(result, "edge_points", "not_measured");
  ASSERT_EQ(static_cast<int>(unmeasured.size()), unmeasured_edges);
  const json csv = client.call("job.result", {{"job", asked}, {"format", "csv"}});
  EXPECT_EQ(csv_row(csv.at("csv").get<std::string>(), unmeasured[0]).at("verdict"), "not_measured");
  const std::string qif = client.call("job.result", {{"job", asked}, {"format", "qif"}}).at("qif");
  EXPECT_NE(qif.find("<OtherInspectionStatus>INCOMPLETE</OtherInspectionStatus>"), std::string::npos);
  EXPECT_EQ(qif.find("<InspectionStatusEnum>PASS</InspectionStatusEnum>"), std::string::npos);
  EXPECT_NE(qif.find("<OtherCharacteristicStatus>NOT_MEASURED</OtherCharacteristicStatus>"), std::string::npos);
  expect_valid_qif(qif, dir / "incomplete.qif");
  EXPECT_NE(client.call("job.report", {{"job", asked}}).at("html").get<std::string>().find("class=\"verdict v-incomplete\">INCOMPLETE"),
            std::string::npos);

  // The same job with what this set-up cannot probe left out on purpose (the plan's own finding), and
  // any feature the first job tried and failed listed with a reason.
  json left_out = request;
  left_out["inspect"] = {{"exclude", {{"not_probeable", true}}}};
  std::vector<int> failed_edges, failed_holes;
  for (const json& e : result.at("edge_points"))
    if (e.at("status") == "failed" || (e.at("status") == "measured" && e.at("inspection").at("verdict") == "not_measured"))
      failed_edges.push_back(e.at("id").get<int>());
  for (const json& h : result.at("holes"))
    if (h.at("status") != "not_planned" && h.at("inspection").at("verdict") == "not_measured") failed_holes.push_back(h.at("id").get<int>());
  if (!failed_edges.empty() || !failed_holes.empty()) {
    left_out["inspect"]["exclude"]["edge_points"] = failed_edges;
    left_out["inspect"]["exclude"]["holes"] = failed_holes;
    left_out["inspect"]["exclude"]["reason"] = "failed in the first job";
  }
  const DoneJob second = run_to_done(client, dir / "scan", left_out);
  const int excluded = second.id;
  const json& record2 = second.record;
  const json& result2 = second.result;
  const json& inspection2 = result2.at("inspection");
  const json& counts2 = inspection2.at("counts");
  EXPECT_EQ(inspection2.at("verdict"), "pass") << inspection2.at("coverage") << " " << counts2.dump();
  EXPECT_EQ(record2.at("verdict").at("verdict"), "pass");
  EXPECT_EQ(counts2.at("edge_points").at("not_measured"), 0) << "a pass carries no not_measured";
  EXPECT_EQ(counts2.at("holes").at("not_measured"), 0);
  EXPECT_EQ(counts2.at("edge_points").at("excluded"), unmeasured_edges) << counts2.dump();
  EXPECT_EQ(counts2.at("holes").at("excluded"), unmeasured_holes) << counts2.dump();
  EXPECT_EQ(counts2.at("edge_points").at("pass"), counts.at("edge_points").at("pass"));
  EXPECT_EQ(inspection2.at("inspect").at("exclude").at("not_probeable"), true);
  ASSERT_FALSE(inspection2.at("exclusions").empty());
  EXPECT_EQ(inspection2.at("exclusions").at(0).at("reason"), "not probeable in this set-up");
  for (int id : ids_judged(result2, "edge_points", "excluded")) {
    const json& reason = result2.at("edge_points").at(static_cast<std::size_t>(id)).at("inspection").at("reason");
    ASSERT_TRUE(reason.is_string()) << "edge point " << id << " excluded without a reason";
  }
  EXPECT_NE(inspection2.at("coverage").get<std::string>().find("excluded (not probeable in this set-up)"), std::string::npos)
      << inspection2.at("coverage");
  const json csv2 = client.call("job.result", {{"job", excluded}, {"format", "csv"}});
  EXPECT_EQ(csv_row(csv2.at("csv").get<std::string>(), unmeasured[0]).at("verdict"), "excluded");
  const std::string qif2 = client.call("job.result", {{"job", excluded}, {"format", "qif"}}).at("qif");
  EXPECT_NE(qif2.find("<InspectionStatusEnum>PASS</InspectionStatusEnum>"), std::string::npos);
  EXPECT_NE(qif2.find("<OtherCharacteristicStatus>EXCLUDED</OtherCharacteristicStatus>"), std::string::npos);
  expect_valid_qif(qif2, dir / "pass.qif");

  // The station's counters say the same.
  EXPECT_EQ(metric(cmmd.http_port(), "cmmd_job_verdicts_total{verdict=\"incomplete\"}"), 1);
  EXPECT_EQ(metric(cmmd.http_port(), "cmmd_job_verdicts_total{verdict=\"pass\"}"), 1);
}

TEST(CmmdInspection, ANominalThatIsACloudOrNoModelIsRefusedAtItsFieldByPreviewAndSubmitAlike) {
  const auto dir = daemon::fresh_folder("inspection-bad-nominal");
  CmmdInstance cmmd(dir / "cmmd", testing::sample_sim_block());
  cmmd.start();
  daemon::RpcClient client = cmmd.client();
  // The nominal's own points without its faces, as a scanner would give them: right size, no edges.
  geometry::PointCloud points;
  points.points = geometry::read_mesh(sample_nominal(dir / "scan")).vertices;
  {
    std::ofstream out(dir / "nominal_points.xyz");
    geometry::write_xyz(out, points);
  }
  const std::string cloud = daemon::upload_model(client, dir / "nominal_points.xyz", 256 * 1024);
  json request = {{"model", daemon::upload_model(client, testing::sample_scan(dir / "scan"), 256 * 1024)},
                  {"spacing_mm", 8},
                  {"registration", testing::sample_measure_plate(dir / "scan")},
                  {"nominal", {{"model", cloud}, {"placement", "given"}}}};
  const auto expect_refused_at_nominal = [&](const std::string& method, const std::string& says) {
    const daemon::RpcError e = testing::error_of(client, method, request, 120);
    EXPECT_EQ(e.code(), daemon::rpc_code::invalid_params) << method << ": " << e.what();
    EXPECT_EQ(e.data().value("path", ""), "/nominal/model") << method << ": " << e.data().dump();
    EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << method << ": " << e.what();
  };
  // Refused at once, not after every touch when the result holds the part against it.
  for (const char* method : {"plan.preview", "job.submit"}) expect_refused_at_nominal(method, "point cloud");
  // A malformed reference is the nominal's fault, not the model's.
  request["nominal"]["model"] = "sha256:0123";
  for (const char* method : {"plan.preview", "job.submit"}) expect_refused_at_nominal(method, "64 hex digits");
  EXPECT_TRUE(client.call("job.list").at("jobs").empty()) << "a job with a bad nominal was queued";

  request["nominal"]["model"] = "sha256:" + std::string(64, 'e');
  const daemon::RpcError absent = testing::error_of(client, "plan.preview", request, 120);
  EXPECT_EQ(absent.code(), daemon::rpc_code::not_found) << absent.what();
  EXPECT_EQ(absent.data().value("path", ""), "/nominal/model") << absent.data().dump();
  EXPECT_EQ(cmmd.terminate(), 0);
}

}  // namespace
}  // namespace cmm
