// Verdicts through the real cmmd: a job on the in-process simulator held against the sample part's
// nominal (a CAD export in the scan's frame), then the same job with one tolerance changed so that a
// hole's diameter fails: the verdict must say so in result.json, the CSV, the HTML report and the QIF
// file (which validates against the QIF 3.0 schema), and in the job record.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "daemon/client/model_upload.hpp"
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

}  // namespace
}  // namespace cmm
