// Stored JSON is input: a 100,000-deep JSON (and values of the wrong type) in each JSON column
// of the store, read by the command that reads that column, gives exit code 2 naming the
// table, row and column, promptly; before, such a value crashed `jobs --json` after 24 s at
// 7.9 GB, made 10,000 levels a 200 MB printout, and an array where a number belongs a bare
// "type_error.302".
#include <SQLiteCpp/SQLiteCpp.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <string>
#include <vector>

#include "support/lab_database.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

struct Column {
  std::string table, column;
  std::string row_sql;  // the id of the row changed
  std::string command;  // a command that reads that column
};

std::vector<Column> JsonColumns(const LabDatabase& lab, const std::string& out) {
  const std::string version1 = "SELECT id FROM calibrations WHERE version = 1";
  return {
      {"sessions", "plan_json", "SELECT 2", "session restore 2"},
      {"station_setups", "rotation_json", "SELECT min(id) FROM station_setups WHERE levelled = 0",
       "reduce --session " + std::to_string(lab.observed_session)},
      {"poses", "joints_json", "SELECT min(id) FROM poses WHERE session_id = 1",
       "session export 1 --poses " + Quoted(out)},
      {"points", "covariance_json",
       "SELECT min(id) FROM points WHERE covariance_json IS NOT NULL AND session_id = " +
           std::to_string(lab.observed_session),
       "reduce --session " + std::to_string(lab.observed_session)},
      {"calibrations", "inputs_json", version1, "versions --robot puma"},
      {"calibrations", "options_json", version1, "versions --robot puma"},
      {"calibrations", "report_json", version1, "versions --robot puma"},
      {"calibrations", "world_from_base_json", version1, "versions --robot puma"},
      {"calibrations", "covariance_json", version1, "versions --robot puma"},
      {"calibrations", "drift_json", "SELECT id FROM calibrations WHERE version = 2",
       "predict --robot puma --joints " + Quoted(lab.joints_csv)},
      {"calibrations", "residual_map_json", "SELECT id FROM calibrations WHERE version = 2",
       "predict --robot puma --joints " + Quoted(lab.joints_csv)},
      {"jobs", "options_json", "SELECT min(id) FROM jobs", "jobs --json"},
      {"jobs", "result_json", "SELECT min(id) FROM jobs", "jobs --json"},
  };
}

// Sets `c`'s cell to `value` (the session discarded first: only a discarded one is restored);
// returns the row's id.
int64_t Store(const std::string& db_path, const Column& c, const std::string& value) {
  SQLite::Database db(db_path, SQLite::OPEN_READWRITE);
  const int64_t row = db.execAndGet(c.row_sql).getInt64();
  SQLite::Statement update(db, "UPDATE " + c.table + " SET " + c.column + " = ? WHERE id = ?");
  update.bind(1, value);
  update.bind(2, row);
  EXPECT_EQ(update.exec(), 1) << c.table << "." << c.column;
  if (c.table == "sessions") db.exec("UPDATE sessions SET state = 'aborted' WHERE id = 2");
  return row;
}

TEST(StoredJson, AHundredThousandDeepJsonInEveryColumnIsNamedNotACrash) {
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  const size_t n = JsonColumns(LabDatabase{}, "").size();
  for (size_t k = 0; k < n; ++k) {
    TempDir dir;
    const LabDatabase lab = CopyLabDatabase(dir.path().string());
    const Column c = JsonColumns(lab, dir.File("out.csv"))[k];
    SCOPED_TRACE(c.table + "." + c.column);
    const int64_t row = Store(lab.path, c, deep);
    const auto r = RunArmsig("--db " + Quoted(lab.path) + " " + c.command);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("table " + c.table + ", row " + std::to_string(row) + ", column " +
                         c.column + ": JSON nested deeper than 64 levels"),
              std::string::npos)
        << r.err;
    EXPECT_LT(r.out.size(), 100000u);  // not the 200 MB printout of a deep value
  }
}

// A value of the wrong type where armsig reads numbers or text is named the same way, not
// with nlohmann's bare "type_error.302".
TEST(StoredJson, AValueOfTheWrongTypeIsNamedWithItsTableRowAndColumn) {
  const struct {
    size_t column;  // index in JsonColumns
    std::string value;
    std::string expected;
  } cases[] = {
      {2, "[[1,2],[3]]", "expected a list of joint angles (numbers)"},
      {0, R"([{"label":[1],"joints_rad":[0,0,0,0,0,0]}])", "not the JSON armsig stores there"},
      {7, "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,[1]]]", "expected a 4x4 matrix of numbers"},
      {1, "{\"not\": \"nine numbers\"}", "expected nine numbers"},
  };
  for (const auto& k : cases) {
    TempDir dir;
    const LabDatabase lab = CopyLabDatabase(dir.path().string());
    const Column c = JsonColumns(lab, dir.File("out.csv"))[k.column];
    SCOPED_TRACE(c.table + "." + c.column + " = " + k.value);
    const int64_t row = Store(lab.path, c, k.value);
    const auto r = RunArmsig("--db " + Quoted(lab.path) + " " + c.command);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("table " + c.table + ", row " + std::to_string(row) + ", column " +
                         c.column + ": " + k.expected),
              std::string::npos)
        << r.err;
  }
}

}  // namespace
}  // namespace armsig::testing
