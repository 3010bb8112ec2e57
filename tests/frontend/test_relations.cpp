// The benchmark's relative metric (frontend/relations.h, `cairn eval
// --relations`): reading relations files, pairing their ends with an
// estimate by stamp or scan index, the errors of known perturbations, and
// relations derived from a shared log's reference poses.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "cairn/frontend/relations.h"
#include "cairn/frontend/trajectory.h"
#include "cairn/graph/text_input.h"
#include "test_util.h"

namespace cairn::frontend {
namespace {

std::string Write(const std::string& name, const std::string& text) {
  const std::string path = cairn::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// A square walk: poses every 0.5 m, one per second.
Trajectory Walk() {
  Trajectory t;
  SE2 p;
  for (int i = 0; i < 40; ++i) {
    t.Add(100.0 + i, p, i);
    p = p * SE2(0.5, 0, i % 10 == 9 ? M_PI / 2 : 0);
  }
  return t;
}

// Relations between each pose and the one `gap` later, from `ref`.
std::vector<Relation> Relations(const Trajectory& ref, int gap) {
  std::vector<Relation> out;
  for (size_t i = 0; i + gap < ref.size(); ++i)
    out.push_back({ref.stamps[i], ref.stamps[i + gap], ref.poses3d[i].Between(ref.poses3d[i + gap]), i + 1});
  return out;
}

TEST(Relations, ReadsLinesAndNamesTheBadOne) {
  const std::string ok = Write("ok.relations",
                               "# comment\n1.5 2.5 1 0 0 0 0 0.5\n\n3 4 0 2 0 0 0 -0.25\n");
  const auto r = ReadRelations(ok);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[1].line, 4u);
  EXPECT_NEAR(r[0].delta.translation().x(), 1, 1e-15);
  EXPECT_NEAR(PlanarView(r[0].delta).theta(), 0.5, 1e-12);
  EXPECT_NEAR(PlanarView(r[1].delta).theta(), -0.25, 1e-12);
  const std::string bad = Write("bad.relations", "1 2 0 0 0 0 0 0\n1 2 0 0 0 0 0\n");
  try {
    ReadRelations(bad);
    FAIL() << "a short line was read";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.line(), 2u);
  }
  EXPECT_THROW(ReadRelations(Write("nan.relations", "1 2 nan 0 0 0 0 0\n")), ParseError);
  EXPECT_THROW(ReadRelations(Write("extra.relations", "1 2 0 0 0 0 0 0 7\n")), ParseError);
}

TEST(Relations, KnownErrorsOfAPerturbedEstimate) {
  const Trajectory ref = Walk();
  const std::vector<Relation> rel = Relations(ref, 1);
  // The reference itself scores zero; a copy moved rigidly too (no alignment needed).
  RelationErrors e = EvaluateRelations(ref, rel, RelationKey::kStamp);
  EXPECT_EQ(e.used, rel.size());
  EXPECT_LT(e.trans.max, 1e-12);
  Trajectory moved;
  for (size_t i = 0; i < ref.size(); ++i) moved.Add(ref.stamps[i], SE2(3, -2, 1.0) * ref.poses[i], i);
  EXPECT_LT(EvaluateRelations(moved, rel, RelationKey::kStamp).trans.max, 1e-12);
  // One pose shifted 0.1 m sideways and turned 2 degrees: the two relations
  // touching it err; the others do not.
  Trajectory bent = ref;
  bent.poses3d[20] = Lift(ref.poses[20] * SE2(0, 0.1, 2 * M_PI / 180));
  e = EvaluateRelations(bent, rel, RelationKey::kStamp);
  EXPECT_NEAR(e.trans.max, 0.1 * 1.0 + 0.0, 0.02);  // the one into pose 20: exactly 0.1 m
  EXPECT_NEAR(e.rot_deg.max, 2.0, 1e-9);
  EXPECT_NEAR(e.rot_deg.mean, 2 * 2.0 / rel.size(), 1e-9);
  EXPECT_NEAR(e.rot_sq_deg2.mean, 2 * 4.0 / rel.size(), 1e-9);
  // By scan index the same.
  const RelationErrors by_scan = EvaluateRelations(
      bent,
      [&] {
        std::vector<Relation> r = rel;
        for (auto& x : r) x.t1 -= 100, x.t2 -= 100;
        return r;
      }(),
      RelationKey::kScanIndex);
  EXPECT_EQ(by_scan.used, rel.size());
  EXPECT_DOUBLE_EQ(by_scan.trans.mean, e.trans.mean);
}

TEST(Relations, UnpairedAndAmbiguousEndsAreCounted) {
  Trajectory est = Walk();
  std::vector<Relation> rel = Relations(est, 2);
  rel[3].t2 = 1e6;           // no pose near
  rel[5].t1 += 0.004;        // within the default 0.01 s
  est.stamps[30] = est.stamps[31];  // two poses share a stamp
  const RelationErrors e = EvaluateRelations(est, rel, RelationKey::kStamp);
  // Relation 3, and the four touching poses 30 or 31.
  EXPECT_EQ(e.unpaired, 5u);
  EXPECT_EQ(e.first_unpaired_line, rel[3].line);
  EXPECT_EQ(e.used, rel.size() - 5);
  EXPECT_EQ(EvaluateRelations(est, rel, RelationKey::kStamp, 0.001).unpaired, 6u);
}

TEST(Relations, CsvTrajectoriesKnowTheirScans) {
  const std::string csv = Write("k.csv",
                                "keyframe,scan,timestamp,x,y,theta\n0,0,1.13486e+09,0,0,0\n"
                                "1,4,1.13486e+09,1,0.5,0.25\n");
  const Trajectory t = ReadTrajectory(csv);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t.scan_index[1], 4);
  EXPECT_DOUBLE_EQ(t.poses[1].theta(), 0.25);
  const Trajectory s = ReadTrajectory(Write("s.csv", "scan,timestamp,x,y,theta\n7,12.5,1,2,3\n"));
  EXPECT_EQ(s.scan_index[0], 7);
  EXPECT_DOUBLE_EQ(s.stamps[0], 12.5);
  try {
    ReadTrajectory(Write("b.csv", "scan,timestamp,x,y,theta\n7,12.5,1,2,3\n8,13,x,2,3\n"));
    FAIL() << "a bad number was read";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.line(), 3u);
  }
}

// Relations derived from aces' reference poses by the script: the log's own
// poses score zero (to the rounding of its printed numbers), its dead
// reckoning far from it, and the tool reports both.
TEST(Relations, DerivedFromASharedLog) {
  const std::string log = cairn::testing::DatasetPath("carmen/aces-corrected.log.gz");
  CAIRN_REQUIRE_DATASET(log);
  const std::string rel = cairn::testing::TempDir() + "/aces.relations";
  int status = 0;
  cairn::testing::RunCommand("python3 " CAIRN_SOURCE_DIR "/scripts/derive_relations.py " + log + " " +
                                 rel + " --loops 50 2>/dev/null",
                             &status);
  ASSERT_EQ(status, 0);
  const std::string json = cairn::testing::TempDir() + "/aces_rel.json";
  const std::string out = cairn::testing::RunCommand(
      std::string(CAIRN_TOOL) + " eval --relations " + rel + " " + log + " --json " + json, &status);
  ASSERT_EQ(status, 0) << out;
  std::ifstream in(json);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_GT(cairn::testing::JsonNumber(text.str(), "used"), 400);
  EXPECT_EQ(cairn::testing::JsonNumber(text.str(), "unpaired"), 0);
  EXPECT_LT(cairn::testing::JsonNumber(text.str(), "mean"), 1e-4);  // trans, the first object
  // REF and --relations together are a usage error; a malformed file is FILE:LINE, exit 1.
  cairn::testing::RunCommand(std::string(CAIRN_TOOL) + " eval --relations " + rel + " " + log +
                                 " " + log + " 2>/dev/null",
                             &status);
  EXPECT_EQ(status, 2);
  const std::string bad = Write("bad_cli.relations", "1 2 0 0 0 0 0 0\nx\n");
  const std::string err = cairn::testing::RunCommand(
      std::string(CAIRN_TOOL) + " eval --relations " + bad + " " + log + " 2>&1", &status);
  EXPECT_EQ(status, 1);
  EXPECT_NE(err.find(bad + ":2:"), std::string::npos) << err;
}

// csail's printed stamps repeat: by time nothing pairs, by scan index all.
TEST(Relations, RepeatedStampsPairByScan) {
  const std::string log = cairn::testing::DatasetPath("carmen/csail-corrected.log.gz");
  CAIRN_REQUIRE_DATASET(log);
  const Trajectory ref = ReadTrajectory(log);
  std::vector<Relation> rel = Relations(ref, 3);
  EXPECT_EQ(EvaluateRelations(ref, rel, RelationKey::kStamp).used, 0u);
  for (size_t i = 0; i < rel.size(); ++i) rel[i].t1 = i, rel[i].t2 = i + 3;
  const RelationErrors e = EvaluateRelations(ref, rel, RelationKey::kScanIndex);
  EXPECT_EQ(e.used, rel.size());
  EXPECT_LT(e.trans.max, 1e-12);
}

}  // namespace
}  // namespace cairn::frontend
