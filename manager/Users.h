// The manager's users and their bearer tokens (docs/security.md), in the job database's file (table `users`). A
// token is shown once, when it is made; only its SHA-256 is stored, so a copy of the database gives no one a
// token. Thread-safe. Every check reads the table (an indexed lookup), so users added, rotated or removed by
// `pflow-manager --add-user` while the manager runs take effect at once.
#pragma once
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "common/Status.h"

struct sqlite3;

namespace pflow::manager {

struct User {
  std::string name;
  bool admin = false;
  double createdAt = 0;  // Unix seconds
};

// A user name: 1 to 64 characters of [A-Za-z0-9._-], starting with a letter or digit.
Status validateUserName(const std::string& name);

class UserStore {
 public:
  // Opens (creating the table if needed) the users of the database at `path` (":memory:": a private one).
  static Result<std::unique_ptr<UserStore>> open(const std::string& path);
  ~UserStore();
  UserStore(const UserStore&) = delete;
  UserStore& operator=(const UserStore&) = delete;

  // Adds a user and returns its token (256 random bits, "pflow_" + 64 hex digits). ALREADY_EXISTS for a taken name.
  Result<std::string> add(const std::string& name, bool admin, double now);
  // A new token for `name`; the old one stops working at once.
  Result<std::string> rotate(const std::string& name);
  Status remove(const std::string& name);
  Result<std::vector<User>> list() const;
  // The user `token` belongs to; UNAUTHENTICATED when it belongs to none (the message never says why further).
  Result<User> authenticate(const std::string& token) const;

 private:
  UserStore(sqlite3* db, std::string path) : m_db(db), m_path(std::move(path)) {}
  Status error(const std::string& what) const;
  sqlite3* m_db;
  std::string m_path;
  mutable std::mutex m_mu;
};

// A new random token, and the hex SHA-256 of a token (what the table stores).
Result<std::string> newToken();
std::string tokenHash(const std::string& token);

}  // namespace pflow::manager
