#include "db/database.h"

#include <SQLiteCpp/Backup.h>
#include <SQLiteCpp/Transaction.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <stdexcept>
#include <thread>
#include <utility>

#include "core/error.h"
#include "db/postgres_connection.h"
#include "db/schema.h"
#include "db/sqlite_connection.h"

namespace armsig::db {

namespace {

// What the read-only look at an existing file found.
enum class FileKind {
  kEmpty,   // a SQLite file without tables, user_version 0 and no application_id: adopted
  kArmsig,  // application_id = kApplicationId
  kLegacy,  // armsig before application_id: user_version 1…latest and armsig's tables
};

// The path as one shell word, for a command the user can paste.
std::string ShellQuoted(const std::string& path) {
  const bool plain = !path.empty() && std::all_of(path.begin(), path.end(), [](unsigned char c) {
    return std::isalnum(c) || std::strchr("_-./:=@%+,", c);
  });
  if (plain) return path;
  std::string out = "'";
  for (char c : path) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string RecoveryAdvice(const std::string& path) {
  // Absolute, so that the command works as printed from any directory.
  std::error_code ec;
  const auto absolute = std::filesystem::absolute(path, ec);
  return "the database file is damaged; nothing was written to it. Recover what is readable "
         "into a new file and use that one: sqlite3 " +
         ShellQuoted(ec ? path : absolute.lexically_normal().string()) +
         " \".recover\" | sqlite3 recovered.db";
}

[[noreturn]] void Refuse(const std::string& path, const std::string& why) {
  throw InputError({path, 0, 0, ""}, why);
}

uint32_t BigEndian32(const unsigned char* bytes) {
  return (uint32_t{bytes[0]} << 24) | (uint32_t{bytes[1]} << 16) | (uint32_t{bytes[2]} << 8) |
         uint32_t{bytes[3]};
}

// The first look, with plain file reads: the SQLite header's magic, user_version (offset
// 60) and application_id (offset 68). Refuses what is certainly not ours or too new without
// letting SQLite touch the file. Returns whether the file is in WAL mode (header bytes 18
// and 19 are 2).
bool CheckHeader(const std::string& path, uintmax_t size) {
  unsigned char header[100] = {};
  std::ifstream in(path, std::ios::binary);
  if (!in) Refuse(path, "cannot read the database file");
  in.read(reinterpret_cast<char*>(header), sizeof header);
  static constexpr char kMagic[] = "SQLite format 3";  // 16 bytes with its NUL
  if (size < sizeof header || in.gcount() != sizeof header ||
      std::memcmp(header, kMagic, sizeof kMagic) != 0) {
    Refuse(path,
           "not an SQLite database (armsig leaves the file as it is; check --db or "
           "$ARMSIG_DB)");
  }
  const uint32_t user_version = BigEndian32(header + 60);
  const int32_t application_id = static_cast<int32_t>(BigEndian32(header + 68));
  if (application_id != 0 && application_id != kApplicationId) {
    Refuse(path, fmt::format("another application's SQLite database (application_id "
                             "0x{:08x}, armsig's is 0x{:08x}); armsig leaves it as it is",
                             static_cast<uint32_t>(application_id),
                             static_cast<uint32_t>(kApplicationId)));
  }
  if (user_version > static_cast<uint32_t>(LatestSchemaVersion())) {
    Refuse(path, fmt::format("schema version {} is newer than this armsig understands ({}); "
                             "the file is left as it is: use a newer armsig",
                             user_version, LatestSchemaVersion()));
  }
  return header[18] == 2 && header[19] == 2;
}

// A path as an SQLite URI file name (RFC 3986 percent-encoding of what a URI reserves).
std::string UriPath(const std::string& path) {
  const std::string absolute = std::filesystem::absolute(path).lexically_normal().string();
  std::string out = "file:";
  for (unsigned char c : absolute) {
    if (std::isalnum(c) || std::strchr("/-_.~", c)) {
      out += static_cast<char>(c);
    } else {
      out += fmt::format("%{:02X}", c);
    }
  }
  return out;
}

// The second look, through a read-only connection: what the file holds and whether it is
// intact. `locked`: an ordinary read-only connection, which takes SQLite's locks (a
// consistent view while others write) but creates the -wal and -shm files of a WAL-mode
// file; otherwise the file is opened immutable (no locks, nothing created), which is only
// a consistent view while nobody changes the file (see LookBeforeWriting).
FileKind Inspect(const std::string& path, const std::string& open_path, bool locked,
                 int busy_timeout_ms) {
  const std::string uri = UriPath(open_path) + (locked ? "?mode=ro" : "?mode=ro&immutable=1");
  try {
    SQLite::Database db(uri, SQLite::OPEN_READONLY | SQLite::OPEN_URI, busy_timeout_ms);
    // One read transaction: the application_id, the user_version and the tables from one
    // snapshot (three autocommit statements could straddle another process's migration).
    SQLite::Transaction snapshot(db);
    const int32_t application_id = db.execAndGet("PRAGMA application_id").getInt();
    const int user_version = db.execAndGet("PRAGMA user_version").getInt();
    std::set<std::string> tables;
    SQLite::Statement query(db, "SELECT name FROM sqlite_master WHERE type = 'table'");
    while (query.executeStep()) tables.insert(query.getColumn(0).getString());

    // The tables every armsig schema version has (later versions add to them).
    const bool armsig_tables =
        std::all_of(LegacyTableNames().begin(), LegacyTableNames().end(),
                    [&](std::string_view t) { return tables.count(std::string(t)) > 0; });
    auto table_list = [&] {
      std::string names;
      for (const auto& t : tables) {
        if (names.size() > 60) {
          names += ", …";
          break;
        }
        names += (names.empty() ? "" : ", ") + t;
      }
      return names.empty() ? std::string("none") : names;
    };
    FileKind kind = FileKind::kArmsig;
    if (application_id == kApplicationId) {
      // armsig's mark, but not what armsig makes: schema version 0 with tables (every
      // migration sets both in one transaction), or a version without armsig's tables. A
      // migration from 0 would fail on the first CREATE TABLE; refused instead, untouched.
      if (user_version == 0 && tables.empty()) {
        kind = FileKind::kEmpty;
      } else if (user_version == 0 || !armsig_tables) {
        Refuse(path, fmt::format("carries armsig's application_id but is not a database armsig "
                                 "made (schema version {}, tables: {}): damaged or edited; armsig "
                                 "leaves it as it is",
                                 user_version, table_list()));
      }
    } else {
      if (application_id == 0 && user_version == 0 && tables.empty()) {
        kind = FileKind::kEmpty;
      } else if (application_id == 0 && user_version >= 1 &&
                 user_version <= LatestSchemaVersion() && armsig_tables) {
        kind = FileKind::kLegacy;
      } else {
        Refuse(path, fmt::format("not an armsig database (application_id {}, user_version {}, "
                                 "tables: {}); armsig leaves it as it is",
                                 application_id, user_version, table_list()));
      }
    }
    if (user_version > LatestSchemaVersion()) {
      Refuse(path, fmt::format("schema version {} is newer than this armsig understands ({}); "
                               "the file is left as it is: use a newer armsig",
                               user_version, LatestSchemaVersion()));
    }
    // quick_check: every page readable, b-trees well formed (O(N), no index cross-check).
    SQLite::Statement check(db, "PRAGMA quick_check");
    std::string problems;
    while (check.executeStep()) {
      const std::string line = check.getColumn(0).getString();
      if (line == "ok") continue;
      if (problems.size() < 200) problems += (problems.empty() ? "" : "; ") + line;
    }
    if (!problems.empty()) Refuse(path, RecoveryAdvice(path) + " (quick_check: " + problems + ")");
    return kind;
  } catch (const SQLite::Exception& e) {
    const int code = e.getErrorCode() & 0xff;
    if (code == SQLITE_CORRUPT || code == SQLITE_NOTADB) {
      Refuse(path, RecoveryAdvice(path) + " (" + e.what() + ")");
    }
    throw;
  }
}

// SQLite does not call the busy handler everywhere: changing the journal mode, opening the
// WAL index while another connection recovers it, and similar steps of opening a file can
// return SQLITE_BUSY at once. This runs `step` again (after a short random pause) until it
// gets through or the busy timeout has passed, so that the timeout applies to every
// statement of opening a file, not only to those SQLite waits for by itself.
template <typename Step>
auto RetryWhileBusy(int timeout_ms, Step&& step) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  std::minstd_rand jitter(std::random_device{}());
  for (;;) {
    try {
      return step();
    } catch (const SQLite::Exception& e) {
      const int code = e.getErrorCode() & 0xff;
      if ((code != SQLITE_BUSY && code != SQLITE_LOCKED) ||
          std::chrono::steady_clock::now() >= deadline) {
        throw;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1 + jitter() % 20));
  }
}

// What tells whether a file changed: its identity, size and modification time, and
// whether it has a -wal file (a connection has it open).
struct FileState {
  dev_t device = 0;
  ino_t inode = 0;
  off_t size = -1;
  timespec modified{};
  bool wal = false;
  bool operator==(const FileState& o) const {
    return device == o.device && inode == o.inode && size == o.size &&
           modified.tv_sec == o.modified.tv_sec && modified.tv_nsec == o.modified.tv_nsec &&
           wal == o.wal;
  }
};

FileState StateOf(const std::string& path) {
  FileState state;
  struct stat s {};
  if (::stat(path.c_str(), &s) == 0) {
    state.device = s.st_dev;
    state.inode = s.st_ino;
    state.size = s.st_size;
    state.modified = s.st_mtim;
  }
  std::error_code ec;
  state.wal = std::filesystem::exists(path + "-wal", ec);
  return state;
}

// A private folder that is removed with everything in it when this goes out of scope.
class ScratchFolder {
 public:
  ScratchFolder() {
    std::string pattern = (std::filesystem::temp_directory_path() / "armsig-look-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) {
      throw std::runtime_error("cannot make a temporary folder (" +
                               std::string(std::strerror(errno)) + ")");
    }
    path_ = pattern;
  }
  ~ScratchFolder() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// A WAL-mode file with a -wal but without its -shm (a database copied with its -wal, or left
// by a crashed writer on another machine): no connection has it open (an open one keeps its
// -shm), and any SQLite reader that also sees the -wal would create the -shm next to it. The
// file and its -wal are looked at as a private copy instead; nothing appears beside them.
FileKind InspectCopy(const std::string& path, int busy_timeout_ms) {
  const ScratchFolder scratch;
  const std::string copy = scratch.path() + "/look.db";
  std::filesystem::copy_file(path, copy);
  std::filesystem::copy_file(path + "-wal", copy + "-wal");
  return Inspect(path, copy, /*locked=*/true, busy_timeout_ms);
}

// The read-only look at an existing file before anything is written to it. A WAL-mode
// file without a -wal file (no connection has it open: the last one to close checkpoints
// and removes it) is read immutable, so that nothing appears next to a file that is then
// refused; such a read takes no locks, so it only counts when the file did not change
// while it was read (another armsig process may be creating or writing the file at the
// same moment: its checkpoint would tear the view). A -wal without its -shm is read as a
// private copy (InspectCopy). Otherwise, and when the file keeps changing, a locked
// read-only connection gives a consistent view (the file is in use by then, its -wal and
// -shm exist, so nothing is created).
FileKind LookBeforeWriting(const std::string& path, int busy_timeout_ms) {
  constexpr int kAttempts = 20;
  for (int attempt = 1;; ++attempt) {
    const FileState before = StateOf(path);
    try {
      const bool wal_mode =
          CheckHeader(path, static_cast<uintmax_t>(std::max<off_t>(before.size, 0)));
      std::error_code ec;
      const bool shm = std::filesystem::exists(path + "-shm", ec);
      if (wal_mode && before.wal && !shm) {
        const FileKind kind = InspectCopy(path, busy_timeout_ms);
        if (StateOf(path) == before) return kind;
      } else {
        const bool locked = !wal_mode || before.wal || attempt == kAttempts;
        const FileKind kind = RetryWhileBusy(
            busy_timeout_ms, [&] { return Inspect(path, path, locked, busy_timeout_ms); });
        if (locked || StateOf(path) == before) return kind;
      }
    } catch (const InputError&) {
      // A refusal stands when the file held still while it was read.
      if (attempt == kAttempts || StateOf(path) == before) throw;
    } catch (const SQLite::Exception&) {
      if (attempt == kAttempts || StateOf(path) == before) throw;
    } catch (const std::filesystem::filesystem_error&) {
      // The -wal went while it was copied: another connection closed (its checkpoint
      // removes the -wal, then the -shm). Look again at what is there now.
      if (attempt == kAttempts) throw;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5 * attempt));
  }
}

[[noreturn]] void RefuseEmpty(const std::string& path) {
  Refuse(path,
         "an empty file, not an armsig database yet: this command only uses what is there and "
         "creates nothing (armsig db init makes it a lab database; check --db or $ARMSIG_DB)");
}

// SQLite's lock bytes (os.h): a connection that has the file open holds a read lock on the
// SHARED range; the last one to close takes a write lock there before it checkpoints the
// -wal into the file and removes it.
constexpr off_t kSqliteSharedFirst = 0x40000000 + 2;
constexpr off_t kSqliteSharedSize = 510;

// A connection for a command that only reads, which creates nothing beside the file (no -wal,
// no -shm: a reader could not remove them again, and on a read-only folder or mount it could
// not create them, "unable to open database file"):
// - a WAL-mode file with its -wal and -shm (a writer has it open, or one crashed): an
//   ordinary read-only connection, which uses both as they are;
// - a -wal without its -shm (a copied database): a private copy, in memory;
// - no -wal (no connection has the file open): immutable, under SQLite's shared lock taken on
//   the file by hand (`lock_fd`), so that a writer that opens the file meanwhile cannot
//   checkpoint into it when it closes; `state` is the file's state then, for
//   Database::ChangedWhileRead;
// - not in WAL mode: an ordinary read-only connection (its locks are on the file itself).
// A file of an older schema (or an older armsig file without application_id) is copied into
// memory and migrated there: the command reads the current schema, the file is not written.
SQLite::Database OpenForReading(const std::string& path, const OpenOptions& options, int* lock_fd,
                                FileState* state) {
  const FileState before = StateOf(path);
  const bool wal_mode = CheckHeader(path, static_cast<uintmax_t>(std::max<off_t>(before.size, 0)));
  std::error_code ec;
  const bool shm = std::filesystem::exists(path + "-shm", ec);
  std::optional<ScratchFolder> scratch;
  std::string open_path = path, parameters = "?mode=ro";
  if (wal_mode && before.wal && !shm) {
    scratch.emplace();
    open_path = scratch->path() + "/copy.db";
    std::filesystem::copy_file(path, open_path);
    std::filesystem::copy_file(path + "-wal", open_path + "-wal");
  } else if (wal_mode && !before.wal) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    // An open file description lock: closing it releases only it, never the locks SQLite
    // connections of this process hold on the file (a POSIX record lock would).
    struct flock shared {};
    shared.l_type = F_RDLCK;
    shared.l_whence = SEEK_SET;
    shared.l_start = kSqliteSharedFirst;
    shared.l_len = kSqliteSharedSize;
    if (fd >= 0 && ::fcntl(fd, F_OFD_SETLK, &shared) == 0 &&
        !std::filesystem::exists(path + "-wal", ec)) {
      *lock_fd = fd;
      *state = before;
      parameters = "?mode=ro&immutable=1";
    } else if (fd >= 0) {
      ::close(fd);  // a writer holds it now: it has made the -wal and -shm, used as they are
    }
  }
  SQLite::Database file(UriPath(open_path) + parameters,
                        SQLite::OPEN_READONLY | SQLite::OPEN_URI | SQLite::OPEN_FULLMUTEX,
                        options.busy_timeout_ms);
  const auto [version, application_id] = RetryWhileBusy(options.busy_timeout_ms, [&] {
    SQLite::Transaction snapshot(file);
    return std::pair<int, int32_t>(file.execAndGet("PRAGMA user_version").getInt(),
                                   file.execAndGet("PRAGMA application_id").getInt());
  });
  if (!scratch && version == LatestSchemaVersion() && application_id == kApplicationId) return file;
  SQLite::Database memory(":memory:", SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
  RetryWhileBusy(options.busy_timeout_ms, [&] {
    SQLite::Backup copy(memory, file);
    copy.executeStep();  // every page
    return 0;
  });
  if (*lock_fd >= 0) {  // the command reads the copy: the file may change now
    ::close(*lock_fd);
    *lock_fd = -1;
  }
  return memory;
}

// A command that writes, on a store it cannot write: said plainly, before SQLite would say
// "attempt to write a readonly database", "unable to open database file" or "disk I/O error".
void RefuseReadOnly(const std::string& path, bool exists) {
  const std::string folder = std::filesystem::path(path).parent_path().empty()
                                 ? std::string(".")
                                 : std::filesystem::path(path).parent_path().string();
  std::error_code ec;
  const bool wal = std::filesystem::exists(path + "-wal", ec);
  const bool shm = std::filesystem::exists(path + "-shm", ec);
  // Not writable, as opposed to gone: another connection's close removes the -wal and the
  // -shm at any moment, and a file that went is no reason to refuse.
  auto refused = [](const std::string& file) {
    return ::access(file.c_str(), W_OK) != 0 && errno != ENOENT;
  };
  std::string why;
  struct statvfs fs {};
  if (::statvfs(exists ? path.c_str() : folder.c_str(), &fs) == 0 && (fs.f_flag & ST_RDONLY)) {
    why = "it lies on a read-only file system (a read-only mount)";
  } else if (exists && ::access(path.c_str(), W_OK) != 0) {
    why = std::string("the file is not writable by this user (") + std::strerror(errno) + ")";
  } else if (wal && refused(path + "-wal")) {
    why = "its " + path + "-wal is not writable by this user";
  } else if (shm && refused(path + "-shm")) {
    why = "its " + path +
          "-shm is not writable by this user (delete it when no armsig process "
          "uses the database)";
  } else if (!(wal && shm) && ::access(folder.c_str(), W_OK) != 0) {
    why = "its folder " + folder + " is not writable by this user (SQLite makes the " +
          (exists ? "-wal and -shm files beside the database" : "database file") + " there)";
  }
  if (why.empty()) return;
  Refuse(path, "read-only: " + why +
                   "; this command writes to the store, nothing was written (the commands that "
                   "only read, such as sessions, versions, robot list, db info, db export and "
                   "predict, work on it as it is)");
}

SQLite::Database OpenOrExplain(const std::string& path, const OpenOptions& options, bool& created,
                               int* lock_fd, FileState* state) {
  std::error_code ec;
  const bool exists = std::filesystem::exists(path, ec);
  if (options.mode != OpenMode::kCreate && !exists) {
    throw InputError({path, 0, 0, ""},
                     "no such database file (this command only uses what is there and creates "
                     "none; check --db or $ARMSIG_DB)");
  }
  if (exists && !std::filesystem::is_regular_file(path, ec)) {
    // A FIFO would block the first read, a device never end: never opened.
    Refuse(path, "not a regular file, so not a database file (check --db or $ARMSIG_DB)");
  }
  const uintmax_t size = exists ? std::filesystem::file_size(path, ec) : 0;
  const bool empty = !exists || ec || size == 0;
  FileKind kind = FileKind::kEmpty;
  if (!empty) {
    // An existing file is looked at read-only first; only what passes is opened for writing.
    kind = LookBeforeWriting(path, options.busy_timeout_ms);
  }
  if (options.mode != OpenMode::kCreate && exists && (empty || kind == FileKind::kEmpty)) {
    RefuseEmpty(path);
  }
  created = empty;
  try {
    if (options.mode == OpenMode::kReadOnly) return OpenForReading(path, options, lock_fd, state);
    RefuseReadOnly(path, exists);
    const int flags = SQLite::OPEN_READWRITE | SQLite::OPEN_FULLMUTEX |
                      (options.mode == OpenMode::kCreate ? SQLite::OPEN_CREATE : 0);
    return SQLite::Database(path, flags, options.busy_timeout_ms);
  } catch (const SQLite::Exception& e) {
    throw InputError({path, 0, 0, ""}, std::string("cannot open database (") + e.what() + ")");
  }
}

std::string CsvField(const Statement& row, int column) {
  switch (row.ColumnType(column)) {
    case Statement::Type::kNull:
      return "";
    case Statement::Type::kInteger:
      return std::to_string(row.Int(column));
    case Statement::Type::kReal: {
      char buffer[40];
      std::snprintf(buffer, sizeof buffer, "%.17g", row.Double(column));
      return buffer;
    }
    default:
      break;
  }
  std::string text = row.Text(column);
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + '"';
}

// The order of a table's rows in an export: insertion order.
std::string ExportOrder(const std::string& table) {
  return table == "calibration_parameters" ? "calibration_id, seq" : "id";
}

// PostgreSQL: the key of the advisory lock a migration holds, and the namespace of the
// robots' write locks ("ARMS" in the high 32 bits).
constexpr int64_t kMigrationLockKey = (int64_t{kApplicationId} << 32) | int64_t{0x5343484D};  // "SCHM"
constexpr int64_t kRobotLockNamespace = int64_t{kApplicationId} << 32;
constexpr int kMigrationStatementTimeoutMs = 30 * 60 * 1000;

}  // namespace

// The lock and state of a file read immutable (OpenForReading).
struct Database::UnlockedRead {
  int fd = -1;
  FileState state;
  ~UnlockedRead() {
    if (fd >= 0) ::close(fd);
  }
};

Database::Database(const std::string& location, OpenOptions options)
    : path_(location),
      busy_timeout_ms_(options.busy_timeout_ms),
      read_only_(options.mode == OpenMode::kReadOnly) {
  CheckStoreAddress(location);
  if (IsPostgresAddress(location)) {
    OpenPostgres(location, options);
  } else {
    OpenSqlite(options);
  }
}

Database::~Database() {
  // The connection first, then the lock that kept writers from checkpointing under it.
  connection_.reset();
  sqlite_.reset();
  unlocked_read_.reset();
}

bool Database::ChangedWhileRead() const {
  if (!unlocked_read_) return false;
  const FileState now = StateOf(path_);
  const FileState& then = unlocked_read_->state;
  return now.device != then.device || now.inode != then.inode || now.size != then.size ||
         now.modified.tv_sec != then.modified.tv_sec ||
         now.modified.tv_nsec != then.modified.tv_nsec;
}

SQLite::Database& Database::sql() {
  if (!sqlite_) {
    throw std::logic_error(path_ + " is a PostgreSQL store: no SQLite handle (use connection())");
  }
  return *sqlite_;
}

void Database::OpenSqlite(const OpenOptions& options) {
  unlocked_read_ = std::make_unique<UnlockedRead>();
  sqlite_ = std::make_unique<SQLite::Database>(
      OpenOrExplain(path_, options, created_, &unlocked_read_->fd, &unlocked_read_->state));
  if (unlocked_read_->fd < 0) unlocked_read_.reset();
  connection_ = std::make_unique<SqliteConnection>(*sqlite_, path_);
  if (read_only_) {
    // The file's connection is read-only, and an older schema was copied into memory: the
    // migration below, if any, changes only that copy.
    sqlite_->exec("PRAGMA foreign_keys=ON");
    if (options.migrate) Migrate();
    return;
  }
  try {
    // WAL: readers never block the writer, and a killed writer leaves the last
    // committed state. synchronous=FULL so a commit also survives a power cut.
    RetryWhileBusy(busy_timeout_ms_, [&] { return sqlite_->exec("PRAGMA journal_mode=WAL"); });
    sqlite_->exec("PRAGMA synchronous=FULL");
    sqlite_->exec("PRAGMA foreign_keys=ON");
  } catch (const SQLite::Exception& e) {
    // The system's reason first (a full disk is not a damaged file).
    const std::string reason = SqliteSystemReason(sqlite_->getHandle(), e.getExtendedErrorCode());
    if (!reason.empty()) {
      throw DatabaseError(path_ + ": cannot be opened for writing (" + reason +
                              "; SQLite: " + e.what() + "); nothing was written",
                          std::to_string(e.getErrorCode()), false);
    }
    throw InputError({path_, 0, 0, ""},
                     std::string("not a usable SQLite database (") + e.what() + ")");
  }
  if (options.migrate) Migrate();
}

void Database::OpenPostgres(const std::string& uri, const OpenOptions& options) {
  // A lock held longer than the busy timeout is an error, as on SQLite.
  ServerTimeouts timeouts;
  timeouts.statement_ms = options.statement_timeout_ms > 0 ? options.statement_timeout_ms
                         : read_only_                     ? 10 * 60 * 1000
                                                          : 60 * 1000;
  timeouts.lock_ms = std::max(busy_timeout_ms_, 1);
  auto connection = std::make_unique<PostgresConnection>(uri, timeouts);  // refuses a password
  path_ = connection->name();
  connection_ = std::move(connection);
  MigratePostgres(options);
  // A command that only reads cannot write by mistake.
  if (read_only_) connection_->Exec("SET default_transaction_read_only = on");
}

void Database::MigratePostgres(const OpenOptions& options) {
  Connection& c = *connection_;
  const int latest = LatestSchemaVersion();
  auto refuse = [&](const std::string& why) { Refuse(path_, why); };
  auto marked = [&] {
    return c.QueryInt("SELECT count(*) FROM information_schema.tables WHERE table_schema = "
                      "current_schema() AND table_name = 'armsig_schema'") > 0;
  };
  auto version = [&] {
    auto q = c.Prepare("SELECT application_id, version FROM armsig_schema");
    if (!q->Step()) refuse("its armsig_schema table is empty: damaged or edited; left as it is");
    if (q->Int(0) != kApplicationId) {
      refuse(fmt::format("armsig_schema carries the application id 0x{:08x}, not armsig's: "
                         "left as it is",
                         static_cast<uint32_t>(q->Int(0))));
    }
    return static_cast<int>(q->Int(1));
  };
  auto too_new = [&](int v) {
    if (v > latest) {
      refuse(fmt::format("schema version {} is newer than this armsig understands ({}); the "
                         "store is left as it is: use a newer armsig",
                         v, latest));
    }
  };
  if (c.QueryInt("SELECT CASE WHEN current_schema() IS NULL THEN 1 ELSE 0 END") != 0) {
    refuse("the connection has no current schema to keep armsig's tables in (search_path names "
           "no existing schema; set options=-csearch_path=NAME in the URI)");
  }
  // Fast path: an armsig store at this version (every open but the first).
  if (marked()) {
    const int v = version();
    too_new(v);
    if (v == latest) return;
    if (options.mode == OpenMode::kReadOnly || !options.migrate) {
      refuse(fmt::format("schema version {} is older than this armsig's ({}); a command that "
                         "only reads does not migrate a server's store: run a writing command "
                         "once (armsig --db URI db init)",
                         v, latest));
    }
  } else if (options.mode != OpenMode::kCreate) {
    refuse("no armsig store in this database (this command only uses what is there and creates "
           "none: armsig --db URI db init creates it; check --db or $ARMSIG_DB)");
  }
  // A migration rewrites whole tables: its statements get half an hour (a stopped server
  // still ends the wait then), the command's own limit after it.
  auto& server = static_cast<PostgresConnection&>(c);
  const int command_limit = server.statement_timeout_ms();
  server.SetStatementTimeout(kMigrationStatementTimeoutMs);
  const std::unique_ptr<void, std::function<void(void*)>> restore(&server, [&](void*) {
    try {
      server.SetStatementTimeout(command_limit);
    } catch (const DatabaseError&) {
      // A lost connection: this store's opening fails anyway.
    }
  });
  Transaction tx(c, TransactionKind::kWrite);
  c.Exec("SELECT pg_advisory_xact_lock(" + std::to_string(kMigrationLockKey) + ")");
  int current = 0;
  if (marked()) {  // looked at again under the lock: another process may have migrated
    current = version();
    too_new(current);
    if (current == latest) return;  // the transaction rolls back: nothing to do
  } else {
    std::string clash;
    auto q = c.Prepare(
        "SELECT table_name FROM information_schema.tables WHERE table_schema = current_schema() "
        "ORDER BY table_name");
    while (q->Step()) {
      const std::string t = q->Text(0);
      const auto tables = TableNames();
      if (std::find(tables.begin(), tables.end(), t) != tables.end())
        clash += (clash.empty() ? "" : ", ") + t;
    }
    if (!clash.empty()) {
      refuse("holds tables of armsig's names that armsig did not make (" + clash +
             "); left as it is: use another database, or another schema "
             "(options=-csearch_path=NAME in the URI)");
    }
    c.Exec("CREATE TABLE armsig_schema (application_id BIGINT NOT NULL, version INTEGER NOT NULL)");
    c.Exec("INSERT INTO armsig_schema VALUES (" + std::to_string(kApplicationId) + ", 0)");
    created_ = true;
  }
  for (int v = current; v < latest; ++v) c.Exec(MigrationSql(v, Backend::kPostgres));
  c.Exec("UPDATE armsig_schema SET version = " + std::to_string(latest));
  tx.Commit();
}

int Database::SchemaVersion() {
  if (sqlite_) return sqlite_->execAndGet("PRAGMA user_version").getInt();
  return static_cast<int>(connection_->QueryInt("SELECT version FROM armsig_schema"));
}

void Database::Migrate() {
  RetryWhileBusy(busy_timeout_ms_, [&] { MigrateOnce(); });
}

void Database::MigrateOnce() {
  SQLite::Database& db = *sqlite_;
  const int latest = LatestSchemaVersion();
  auto application_id = [&] { return db.execAndGet("PRAGMA application_id").getInt(); };
  if (SchemaVersion() == latest && application_id() == kApplicationId) return;
  // An IMMEDIATE transaction takes the write lock first, so two processes opening a fresh
  // file at once cannot both migrate; the loser waits, then sees the new version.
  SQLite::Transaction tx(db, SQLite::TransactionBehavior::IMMEDIATE);
  // Looked at again under the lock (another process may have migrated, or replaced the file).
  const int current = SchemaVersion();
  const int id = application_id();
  if (current > latest) {
    Refuse(path_, fmt::format("schema version {} is newer than this armsig understands ({})",
                              current, latest));
  }
  if (id != 0 && id != kApplicationId) {
    Refuse(path_, fmt::format("another application's SQLite database (application_id 0x{:08x})",
                              static_cast<uint32_t>(id)));
  }
  for (int v = current; v < latest; ++v) db.exec(MigrationSql(v, Backend::kSqlite));
  db.exec("PRAGMA user_version=" + std::to_string(latest));
  db.exec("PRAGMA application_id=" + std::to_string(kApplicationId));
  tx.commit();  // rolled back by the destructor when a migration throws
}

std::vector<Database::TableCount> Database::RowCounts() {
  std::vector<TableCount> counts;
  for (std::string_view table : TableNames()) {
    const std::string name(table);
    counts.push_back({name, connection_->QueryInt("SELECT count(*) FROM " + name)});
  }
  return counts;
}

std::string Database::ExportCsv(const std::string& table) {
  const auto tables = TableNames();
  if (std::find(tables.begin(), tables.end(), table) == tables.end()) {
    std::string known;
    for (std::string_view t : tables) known += (known.empty() ? "" : ", ") + std::string(t);
    throw InputError("unknown table '" + table + "' (expected one of: " + known + ")");
  }
  auto query = connection_->Prepare("SELECT * FROM " + table + " ORDER BY " + ExportOrder(table));
  bool row = query->Step();  // PostgreSQL knows the columns once the statement ran
  std::string out;
  for (int c = 0; c < query->Columns(); ++c) out += (c ? "," : "") + query->ColumnName(c);
  out += '\n';
  for (; row; row = query->Step()) {
    for (int c = 0; c < query->Columns(); ++c) {
      if (c) out += ',';
      out += CsvField(*query, c);
    }
    out += '\n';
  }
  return out;
}

void LockSessionForWrite(Database& database, int64_t session_id) {
  if (database.backend() != Backend::kPostgres) return;
  auto lock = database.connection().Prepare("SELECT id FROM sessions WHERE id = ? FOR UPDATE");
  lock->Bind(1, session_id);
  lock->Execute();
}

void LockRobotForWrite(Connection& connection, int64_t robot_id) {
  if (connection.backend() != Backend::kPostgres) return;
  auto lock = connection.Prepare("SELECT pg_advisory_xact_lock(CAST(? AS BIGINT))");
  lock->Bind(1, static_cast<int64_t>(kRobotLockNamespace | (robot_id & 0xffffffff)));
  lock->Execute();
}

}  // namespace armsig::db
