// job.view on a job folder written by hand: nothing but nulls before the job has made its files,
// then the planned points and holes with their touch ids, T_M_S, the journal's touches (a torn tail
// left out) and the result cut down to what the dashboard shows.
#include "daemon/job_view.hpp"

#include <fstream>

#include <gtest/gtest.h>

#include "daemon/client/base64.hpp"
#include "daemon/job_registration.hpp"
#include "daemon/touch_journal.hpp"
#include "fresh_folder.hpp"
#include "hal/description/eigen_json.hpp"

namespace cmm::daemon {
namespace {

using nlohmann::json;

JournalEntry made(int touch) {
  JournalEntry e;
  e.touch_id = touch;
  e.result.contact = true;
  e.result.centre = hal::Vec3(1, 2, 3);
  e.result.tip_id = "T1";
  return e;
}

TEST(JobView, AJobThatHasMadeNothingYetIsAllNulls) {
  JobStore store(fresh_folder("view-empty"));
  const int id = store.create({{"model", "file:a.ply"}}, "a", "file:a.ply").id;
  const json view = job_view(store, id);
  EXPECT_EQ(view.at("job"), id);
  for (const char* key : {"reference_ply", "T_M_S", "result"}) EXPECT_TRUE(view.at(key).is_null()) << key;
  for (const char* key : {"edge_points", "holes", "touches_done"}) EXPECT_EQ(view.at(key), json::array()) << key;
}

TEST(JobView, GathersTheMeshThePlanTheJournalAndTheResult) {
  JobStore store(fresh_folder("view-files"));
  const int id = store.create({{"model", "file:a.ply"}}, "a", "file:a.ply").id;
  const std::string ply("ply\nformat binary_little_endian 1.0\nend_header\n\x01\x00\xff", 48);
  store.write(id, JobFile::reference_mesh, ply);
  JobRegistration registration;
  registration.T_M_S.translation() = Eigen::Vector3d(100, 200, 0);
  registration.radius_mm = 1;
  registration.tip = "T1";
  store.write(id, JobFile::registration, to_json(registration).dump());
  const json plan = {
      {"edge_points",
       {{{"id", 0}, {"position", {1, 2, 3}}, {"kind", "sharp_edge"}, {"method", "two_touch"}, {"probeable", true},
         {"reason", nullptr}, {"touches", {0, 1}}, {"window", nullptr}},
        {{"id", 1}, {"position", {4, 5, 6}}, {"kind", "hole_rim"}, {"method", "none"}, {"probeable", false},
         {"reason", "on the plate"}, {"touches", json::array()}}}},
      {"holes",
       {{{"id", 0}, {"centre", {7, 8, 9}}, {"axis", {0, 0, 1}}, {"radius", 5}, {"bore", {{"depth_mm", 2}, {"touches", {2, 3}}}},
         {"bore_reason", nullptr}},
        {{"id", 1}, {"centre", {0, 0, 0}}, {"axis", {0, 0, 1}}, {"radius", 21}, {"bore", nullptr}, {"bore_reason", "too deep"}}}},
      {"program", json::array()}};
  store.write(id, JobFile::plan, plan.dump());
  {
    TouchJournal journal(store.path(id, JobFile::touches));
    journal.append(made(1));
    journal.append(made(0));
  }
  {  // a crash mid-append: not a touch made
    std::ofstream out(store.path(id, JobFile::touches), std::ios::app);
    out << "{\"touch\": 2, \"cont";
  }
  json view = job_view(store, id);
  EXPECT_EQ(decode_base64(view.at("reference_ply").get<std::string>()), ply);
  EXPECT_EQ(view.at("T_M_S"), description::transform_json(registration.T_M_S));
  ASSERT_EQ(view.at("edge_points").size(), 2u);
  EXPECT_EQ(view["edge_points"][0], (json{{"id", 0}, {"position_S", {1, 2, 3}}, {"kind", "sharp_edge"}, {"method", "two_touch"},
                                          {"probeable", true}, {"reason", nullptr}, {"touches", {0, 1}}}));
  EXPECT_EQ(view["edge_points"][1]["reason"], "on the plate");
  ASSERT_EQ(view.at("holes").size(), 2u);
  EXPECT_EQ(view["holes"][0], (json{{"id", 0}, {"centre_S", {7, 8, 9}}, {"axis_S", {0, 0, 1}}, {"radius", 5},
                                     {"reason", nullptr}, {"touches", {2, 3}}}));
  EXPECT_EQ(view["holes"][1]["touches"], json::array());
  EXPECT_EQ(view["holes"][1]["reason"], "too deep");
  EXPECT_EQ(view.at("touches_done"), (json{1, 0}));
  EXPECT_TRUE(view.at("result").is_null());

  const json result = json::parse(R"({
    "summary": {"edge_points": {"total": 2}},
    "inspection": {"verdict": "pass"},
    "edge_points": [
      {"id": 0, "status": "measured", "reason": null, "measured_S": {"position": [1, 2, 3.01]}, "deviation_mm": 0.01,
       "sigma_mm": 0.001, "inspection": {"verdict": "pass"}, "reference_S": [1, 2, 3]},
      {"id": 1, "status": "not_planned", "reason": "on the plate", "measured_S": null, "deviation_mm": null, "sigma_mm": null}],
    "holes": [
      {"id": 0, "status": "measured", "measured_S": {"centre": [7, 8, 7]}, "diameter_mm": 10.01,
       "diameter_deviation_mm": 0.01, "centre_deviation_mm": 0.002, "centre_sigma_mm": 0.001,
       "nominal": {"diameter_mm": 10}, "inspection": {"verdict": "pass"}}]})");
  store.write(id, JobFile::result, result.dump());
  view = job_view(store, id);
  const json& r = view.at("result");
  EXPECT_EQ(r.at("inspection"), result["inspection"]);
  EXPECT_EQ(r.at("summary"), result["summary"]);
  ASSERT_EQ(r.at("edge_points").size(), 2u);
  EXPECT_EQ(r["edge_points"][0]["deviation_mm"], 0.01);
  EXPECT_EQ(r["edge_points"][0]["inspection"]["verdict"], "pass");
  EXPECT_FALSE(r["edge_points"][0].contains("reference_S"));  // only what a click shows
  EXPECT_TRUE(r["edge_points"][1]["inspection"].is_null());    // a result without a nominal reads as null
  EXPECT_EQ(r["holes"][0]["diameter_mm"], 10.01);
  EXPECT_EQ(r["holes"][0]["nominal"]["diameter_mm"], 10);  // the model's hole
  EXPECT_EQ(r["holes"][0]["inspection"]["verdict"], "pass");
}

TEST(JobView, AResultThatIsNotCmmdsIsAnError) {
  JobStore store(fresh_folder("view-bad"));
  const int id = store.create({{"model", "file:a.ply"}}, "a", "file:a.ply").id;
  store.write(id, JobFile::result, "{\"edge_points\": 3");
  EXPECT_THROW(job_view(store, id), nlohmann::json::exception);
}

}  // namespace
}  // namespace cmm::daemon
