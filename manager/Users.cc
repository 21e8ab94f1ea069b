#include "manager/Users.h"

#include <openssl/evp.h>
#include <openssl/rand.h>
#include <sqlite3.h>

#include "common/Token.h"
#include "manager/Sqlite.h"

namespace pflow::manager {
namespace {

std::string hex(const unsigned char* p, std::size_t n) {
  static const char* digits = "0123456789abcdef";
  std::string out(2 * n, '0');
  for (std::size_t i = 0; i < n; ++i) {
    out[2 * i] = digits[p[i] >> 4];
    out[2 * i + 1] = digits[p[i] & 15];
  }
  return out;
}

}  // namespace

Status validateUserName(const std::string& name) {
  if (name.empty() || name.size() > 64) return invalidArgument("user name: 1 to 64 characters (got " + std::to_string(name.size()) + ")");
  auto alnum = [](char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9'); };
  if (!alnum(name[0])) return invalidArgument("user name: must start with a letter or digit");
  for (char c : name)
    if (!alnum(c) && c != '.' && c != '_' && c != '-') return invalidArgument("user name: only letters, digits, '.', '_' and '-'");
  return Status::ok();
}

Result<std::string> newToken() {
  unsigned char bytes[32];
  if (RAND_bytes(bytes, sizeof bytes) != 1) return internalError("no random bytes for a token");
  return kTokenPrefix + hex(bytes, sizeof bytes);
}

std::string tokenHash(const std::string& token) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  EVP_Digest(token.data(), token.size(), md, &n, EVP_sha256(), nullptr);
  return hex(md, n);
}

Result<std::unique_ptr<UserStore>> UserStore::open(const std::string& path) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    std::string msg = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
    sqlite3_close(db);
    return ioError("cannot open user database " + path + ": " + msg);
  }
  std::unique_ptr<UserStore> store(new UserStore(db, path));
  sqlite3_busy_timeout(db, 5000);
  char* err = nullptr;
  if (sqlite3_exec(db,
                   "CREATE TABLE IF NOT EXISTS users(name TEXT PRIMARY KEY, token_sha256 TEXT NOT NULL UNIQUE, "
                   "admin INTEGER NOT NULL, created_at REAL NOT NULL);",
                   nullptr, nullptr, &err) != SQLITE_OK) {
    std::string msg = err ? err : "unknown error";
    sqlite3_free(err);
    return ioError("user database " + path + ": " + msg);
  }
  return store;
}

UserStore::~UserStore() { sqlite3_close(m_db); }

Status UserStore::error(const std::string& what) const {
  return ioError("user database " + m_path + ": " + what + ": " + sqlite3_errmsg(m_db));
}

Result<std::string> UserStore::add(const std::string& name, bool admin, double now) {
  if (Status s = validateUserName(name); !s) return s;
  auto token = newToken();
  if (!token) return token.status();
  std::lock_guard lock(m_mu);
  Stmt st(m_db, "INSERT INTO users(name, token_sha256, admin, created_at) VALUES(?1, ?2, ?3, ?4)");
  if (!st.ok()) return error("preparing the user insert");
  st.text(1, name);
  st.text(2, tokenHash(token.value()));
  st.i64(3, admin ? 1 : 0);
  st.real(4, now);
  const int rc = st.step();
  if (rc == SQLITE_CONSTRAINT) return alreadyExists("user " + name + " exists (rotate its token instead)");
  if (rc != SQLITE_DONE) return error("adding user " + name);
  return token;
}

Result<std::string> UserStore::rotate(const std::string& name) {
  auto token = newToken();
  if (!token) return token.status();
  std::lock_guard lock(m_mu);
  Stmt st(m_db, "UPDATE users SET token_sha256 = ?1 WHERE name = ?2");
  if (!st.ok()) return error("preparing the token update");
  st.text(1, tokenHash(token.value()));
  st.text(2, name);
  if (st.step() != SQLITE_DONE) return error("rotating the token of " + name);
  if (sqlite3_changes(m_db) == 0) return notFound("no user " + name);
  return token;
}

Status UserStore::remove(const std::string& name) {
  std::lock_guard lock(m_mu);
  Stmt st(m_db, "DELETE FROM users WHERE name = ?1");
  if (!st.ok()) return error("preparing the user delete");
  st.text(1, name);
  if (st.step() != SQLITE_DONE) return error("removing user " + name);
  if (sqlite3_changes(m_db) == 0) return notFound("no user " + name);
  return Status::ok();
}

Result<std::vector<User>> UserStore::list() const {
  std::lock_guard lock(m_mu);
  Stmt st(m_db, "SELECT name, admin, created_at FROM users ORDER BY name");
  if (!st.ok()) return error("preparing the user query");
  std::vector<User> out;
  int rc;
  while ((rc = st.step()) == SQLITE_ROW) out.push_back(User{st.colText(0), st.colI64(1) != 0, st.colReal(2)});
  if (rc != SQLITE_DONE) return error("reading users");
  return out;
}

Result<User> UserStore::authenticate(const std::string& token) const {
  if (token.empty()) return unauthenticated("no token: set PFLOW_TOKEN or `token:` in ~/.config/pflow/config.yaml");
  if (!looksLikeToken(token)) return unauthenticated("the token is not valid");
  std::lock_guard lock(m_mu);
  Stmt st(m_db, "SELECT name, admin, created_at FROM users WHERE token_sha256 = ?1");
  if (!st.ok()) return error("preparing the token query");
  st.text(1, tokenHash(token));
  const int rc = st.step();
  if (rc == SQLITE_ROW) return User{st.colText(0), st.colI64(1) != 0, st.colReal(2)};
  if (rc != SQLITE_DONE) return error("checking a token");
  return unauthenticated("the token is not valid");
}

}  // namespace pflow::manager
