// A prepared SQLite statement that finalizes itself: the manager's stores (JobStore, UserStore) share it.
#pragma once
#include <sqlite3.h>

#include <cstdint>
#include <string>

namespace pflow::manager {

class Stmt {
 public:
  Stmt(sqlite3* db, const char* sql) { m_rc = sqlite3_prepare_v2(db, sql, -1, &m_s, nullptr); }
  ~Stmt() { sqlite3_finalize(m_s); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;
  bool ok() const { return m_rc == SQLITE_OK; }
  void text(int i, const std::string& v) { sqlite3_bind_text(m_s, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT); }
  void i64(int i, std::int64_t v) { sqlite3_bind_int64(m_s, i, v); }
  void real(int i, double v) { sqlite3_bind_double(m_s, i, v); }
  int step() { return sqlite3_step(m_s); }
  std::string colText(int i) const {
    const auto* p = sqlite3_column_text(m_s, i);
    return p ? std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(sqlite3_column_bytes(m_s, i))) : std::string();
  }
  std::int64_t colI64(int i) const { return sqlite3_column_int64(m_s, i); }
  double colReal(int i) const { return sqlite3_column_double(m_s, i); }

 private:
  sqlite3_stmt* m_s = nullptr;
  int m_rc = SQLITE_ERROR;
};

}  // namespace pflow::manager
