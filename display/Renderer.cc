#include "display/Renderer.h"

#include <httplib.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <regex>
#include <sstream>

#include "display/ArrayFrames.h"
#include <nlohmann/json.hpp>

extern char** environ;

namespace pflow::display {
namespace fs = std::filesystem;
namespace {

const std::regex kAxisValue(R"(^([xyz])=([-+]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][-+]?[0-9]+)?)$)");

std::string randomKey() {
  std::random_device rd;
  static const char* hex = "0123456789abcdef";
  std::string key;
  for (int i = 0; i < 32; ++i) key += hex[rd() & 15];
  return key;
}

std::string urlEncode(const std::string& s) {
  std::string out;
  static const char* hex = "0123456789ABCDEF";
  for (unsigned char c : s) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') out += char(c);
    else out += '%', out += hex[c >> 4], out += hex[c & 15];
  }
  return out;
}

std::string executableDir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : exe.parent_path().string();
}

bool executable(const fs::path& p) { return ::access(p.c_str(), X_OK) == 0 && fs::is_regular_file(p); }

std::string tail(const fs::path& file, std::size_t lines) {
  std::ifstream in(file);
  std::vector<std::string> all;
  for (std::string line; std::getline(in, line);)
    if (line.find("dbus") == std::string::npos && line.find("D-Bus") == std::string::npos) all.push_back(line);
  std::string out;
  for (std::size_t i = all.size() > lines ? all.size() - lines : 0; i < all.size(); ++i) out += "\n  " + all[i].substr(0, 300);
  return out;
}

// The page's query: the options it reads (web/src/render.js).
std::string pageQuery(const RenderOptions& o, const std::string& key, bool sliceFluid) {
  std::string q = "key=" + key + "&width=" + std::to_string(o.width) + "&height=" + std::to_string(o.height);
  auto add = [&q](const char* name, const std::string& v) {
    if (!v.empty()) q += std::string("&") + name + "=" + urlEncode(v);
  };
  if (o.plot) {
    std::string series;
    for (const auto& s : o.series) series += (series.empty() ? "" : ",") + s;
    add("plot", "1");
    add("series", series);
    add("title", o.title);
    return q;
  }
  std::string view = o.view;
  if (view.empty() && !o.slice.empty()) view = o.slice[0] == 'x' ? "side" : o.slice[0] == 'y' ? "front" : "top";
  add("view", view);
  add("color", o.colorBy);
  add("colormap", o.colormap);
  auto number = [](double v) {  // every digit: a range of 1e-7 must not become 0.000000
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return std::string(buf);
  };
  if (o.min) add("min", number(*o.min));
  if (o.max) add("max", number(*o.max));
  add("clip", o.clip);
  add("slice", o.slice);
  if (!o.slice.empty()) add("field", o.field.empty() ? (sliceFluid ? "fluid_fraction" : "solid_fraction") : o.field);
  if (o.streamlines) add("streamlines", "1");
  add("particles", (o.particlesSet ? o.particles : o.slice.empty()) ? "1" : "0");
  add("title", o.title);
  return q;
}

// Chromium's process group while one runs: SIGINT or SIGTERM to `pflow render` takes it down too (it is in a group
// of its own, which a terminal's Ctrl-C does not reach).
std::atomic<pid_t> g_chromiumGroup{0};
struct sigaction g_oldInt, g_oldTerm;
extern "C" void onRenderSignal(int sig) {
  if (const pid_t g = g_chromiumGroup.load(); g > 0) ::kill(-g, SIGKILL);
  ::sigaction(SIGINT, &g_oldInt, nullptr);
  ::sigaction(SIGTERM, &g_oldTerm, nullptr);
  ::raise(sig);
}

struct Exchange {
  std::mutex mutex;
  std::condition_variable cv;
  bool done = false;
  std::string png, error, timing;
};

}  // namespace

Status validateRenderOptions(const RenderOptions& o) {
  std::vector<std::string> errors;
  if (o.width < 200 || o.width > 8192) errors.push_back("width " + std::to_string(o.width) + ": between 200 and 8192 pixels");
  if (o.height < 200 || o.height > 8192) errors.push_back("height " + std::to_string(o.height) + ": between 200 and 8192 pixels");
  if (!o.view.empty() && o.view != "iso" && o.view != "top" && o.view != "front" && o.view != "side")
    errors.push_back("--view '" + o.view + "': one of iso, top, front, side");
  if (!o.clip.empty() && !std::regex_match(o.clip, kAxisValue))
    errors.push_back("--clip '" + o.clip + "': AXIS=VALUE, AXIS one of x, y, z and VALUE a number in m (e.g. y=0.05)");
  if (!o.slice.empty() && !std::regex_match(o.slice, kAxisValue))
    errors.push_back("--slice '" + o.slice + "': AXIS=VALUE, AXIS one of x, y, z and VALUE a number in m (e.g. y=0.05)");
  if (o.slice.empty() && !o.field.empty()) errors.push_back("--field " + o.field + ": needs --slice AXIS=VALUE");
  if (o.slice.empty() && o.streamlines) errors.push_back("--streamlines: needs --slice AXIS=VALUE");
  if (o.min && o.max && !(*o.min < *o.max)) errors.push_back("--range: the minimum must be below the maximum");
  if ((o.min && !std::isfinite(*o.min)) || (o.max && !std::isfinite(*o.max))) errors.push_back("--range: finite numbers");
  static const char* maps[] = {"viridis", "grey", "coolwarm", "inferno", "categories"};
  if (!o.colormap.empty() && std::find(std::begin(maps), std::end(maps), o.colormap) == std::end(maps))
    errors.push_back("--colormap '" + o.colormap + "': one of viridis, grey, coolwarm, inferno, categories");
  if (o.output.empty()) errors.push_back("-o: an output file name");
  else {
    const fs::path dir = fs::absolute(o.output).parent_path();
    if (!fs::is_directory(dir)) errors.push_back("-o " + o.output + ": folder " + dir.string() + " does not exist");
  }
  if (!(o.timeoutSeconds > 0)) errors.push_back("--timeout: more than 0 s");
  if (errors.empty()) return Status::ok();
  std::string msg = std::string(o.plot ? "pflow plot: " : "pflow render: ") + std::to_string(errors.size()) + " problem" + (errors.size() > 1 ? "s" : "") + ":";
  for (const auto& e : errors) msg += "\n  " + e;
  return invalidArgument(msg);
}

Result<std::string> findChromium(const std::string& given) {
  if (!given.empty()) {
    if (executable(given)) return given;
    return notFound("Chromium '" + given + "' is not an executable file");
  }
  if (const char* env = std::getenv("PFLOW_CHROMIUM"); env && *env) {
    if (executable(env)) return std::string(env);
    return notFound("PFLOW_CHROMIUM=" + std::string(env) + " is not an executable file");
  }
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "/usr/bin:/bin");
  std::vector<std::string> folders;
  for (std::string d; std::getline(dirs, d, ':');) folders.push_back(d.empty() ? "." : d);
  for (const char* name : {"chromium", "chromium-browser", "google-chrome", "google-chrome-stable"})
    for (const auto& d : folders)
      if (executable(fs::path(d) / name)) return (fs::path(d) / name).string();
  return notFound("pflow render draws with headless Chromium, and none was found (looked for chromium, chromium-browser, "
                  "google-chrome on PATH). Install it (Debian: apt-get install chromium) or set PFLOW_CHROMIUM");
}

Result<std::string> findPageDir(const std::string& given) {
  std::vector<std::string> places;
  if (!given.empty()) places.push_back(given);
  else {
    if (const char* env = std::getenv("PFLOW_WEB_DIR"); env && *env) places.push_back(env);
    const std::string exe = executableDir();
    if (!exe.empty()) places.push_back((fs::path(exe) / ".." / "web").lexically_normal().string());
  }
  for (const auto& p : places)
    if (fs::is_regular_file(fs::path(p) / "render.html") && fs::is_regular_file(fs::path(p) / "render.js")) return p;
  std::string looked;
  for (const auto& p : places) looked += (looked.empty() ? "" : ", ") + p;
  return notFound("the viewer's page (render.html, render.js) is not in " + (looked.empty() ? std::string("any known place") : looked) +
                  ": build the target pflow_web_page (deploy/build.sh) or set PFLOW_WEB_DIR");
}

Result<RenderReport> renderSnapshot(const RenderOptions& o, SnapshotSource& source, const std::string& token,
                                    const SnapshotRequest& request) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string what = o.plot ? "pflow plot" : "pflow render";
  if (Status st = validateRenderOptions(o); !st) return st;
  auto chromium = findChromium(o.chromium);
  if (!chromium) return chromium.status();
  auto pageDir = findPageDir(o.pageDir);
  if (!pageDir) return pageDir.status();

  // 1. The snapshot, in the viewer's binary form.
  RenderReport report;
  std::string data;
  bool fluid = false;
  SnapshotRequest req = request;
  req.grid = !o.plot && !o.slice.empty();
  req.geometry = !o.plot;
  req.probes = o.plot;
  req.particles = !o.plot;
  bool anySeries = false;
  const Status read = source.readSnapshot(
      token, req, [&](std::int64_t step, double time) { report.step = step, report.time = time, appendHeaderFrame(data, step, time); },
      [&](const ArrayPiece& p) {
        if (p.section == "particles" && p.name == "position") report.particles = p.totalRows;
        if (p.section == "grid" && p.name == "fluid_fraction") fluid = true;
        if (p.section == "probes") anySeries = true;
        appendPieceFrame(data, p);
        return true;
      });
  if (!read) return read;
  if (data.empty()) return notFound("no snapshot to draw");
  if (o.plot && !anySeries)
    return notFound("no time series stored for this run (DEM runs record them since this version; SPH runs need probes)");

  // 2. A one-shot loopback server: the page, the data at /data/KEY, the picture posted to /result/KEY.
  const std::string key = randomKey();
  Exchange ex;
  httplib::Server server;
  server.set_payload_max_length(std::size_t(512) << 20);
  std::atomic<bool> served{false};
  server.Get("/data/" + key, [&data, &served](const httplib::Request&, httplib::Response& res) {
    if (served.exchange(true)) {  // once: the page's one fetch
      res.status = 410;
      return;
    }
    res.set_content(data.data(), data.size(), "application/x-pflow-arrays");
  });
  auto finish = [&ex](std::string png, std::string error, std::string timing) {
    std::lock_guard<std::mutex> lock(ex.mutex);
    if (ex.done) return;
    ex.png = std::move(png), ex.error = std::move(error), ex.timing = std::move(timing), ex.done = true;
    ex.cv.notify_all();
  };
  server.Post("/result/" + key, [&finish](const httplib::Request& req, httplib::Response&) {
    finish(req.body, "", req.get_header_value("X-Render-Timing"));
  });
  server.Post("/error/" + key, [&finish](const httplib::Request& req, httplib::Response&) {
    finish("", req.body.empty() ? "the page failed without a message" : req.body.substr(0, 2000), "");
  });
  for (const char* file : {"/render.html", "/render.js"}) {
    const std::string path = (fs::path(pageDir.value()) / (file + 1)).string();
    server.Get(file, [path, file](const httplib::Request&, httplib::Response& res) {
      std::ifstream in(path, std::ios::binary);
      std::stringstream body;
      body << in.rdbuf();
      res.set_content(body.str(), std::string(file).ends_with(".js") ? "text/javascript" : "text/html");
    });
  }
  const int port = server.bind_to_any_port("127.0.0.1");
  if (port <= 0) return unavailable(what + ": cannot listen on a loopback port");
  std::thread serving([&server] { server.listen_after_bind(); });
  for (int i = 0; i < 5000 && !server.is_running(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));  // stop() needs it running

  // 3. Chromium, headless, with a throw-away profile in a folder only this user can enter (mkdtemp: 0700). The key
  // stays off Chromium's command line, which every local user can read: Chromium opens a file in that folder,
  // which sends it on to the page's address with the key.
  std::error_code ec;
  std::string pattern = (fs::temp_directory_path(ec) / "pflow-render-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) {
    server.stop();
    serving.join();
    return unavailable(what + ": cannot make a temporary folder " + pattern + ": " + std::strerror(errno));
  }
  const fs::path profile = pattern;
  const fs::path log = profile / "chromium.log";
  const std::string target = "http://127.0.0.1:" + std::to_string(port) + "/render.html?" + pageQuery(o, key, fluid);
  const fs::path start = profile / "start.html";
  {
    std::ofstream f(start);
    f << "<!doctype html><meta charset=\"utf-8\"><script>location.replace(" << nlohmann::json(target).dump() << ");</script>\n";
  }
  const std::string url = "file://" + start.string();
  std::vector<std::string> args = {chromium.value(),
                                   "--headless=new",
                                   "--use-angle=swiftshader",
                                   "--enable-unsafe-swiftshader",  // software WebGL: the same picture on any machine
                                   "--window-size=" + std::to_string(o.width) + "," + std::to_string(o.height),
                                   "--hide-scrollbars",
                                   "--mute-audio",
                                   "--no-first-run",
                                   "--no-default-browser-check",
                                   "--disable-extensions",
                                   "--disable-background-networking",
                                   "--disable-component-update",
                                   "--disable-sync",
                                   "--user-data-dir=" + profile.string(),
                                   url};
  if (::geteuid() == 0) args.insert(args.begin() + 1, "--no-sandbox");  // Chromium refuses its sandbox to root
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attr, 0);  // its own process group: killed as a whole
  pid_t pid = -1;
  struct sigaction handler {};
  handler.sa_handler = onRenderSignal;
  ::sigemptyset(&handler.sa_mask);
  ::sigaction(SIGINT, &handler, &g_oldInt);
  ::sigaction(SIGTERM, &handler, &g_oldTerm);
  const int spawned = posix_spawn(&pid, argv[0], &actions, &attr, argv.data(), environ);
  if (spawned == 0) g_chromiumGroup = pid;
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);

  // 4. Wait for the picture, the page's error, Chromium's exit or the time limit.
  std::string failure;
  int exitStatus = 0;
  bool exited = false;
  if (spawned != 0) failure = "cannot start " + chromium.value() + ": " + std::strerror(spawned);
  else {
    const auto deadline = t0 + std::chrono::duration<double>(o.timeoutSeconds);
    std::unique_lock<std::mutex> lock(ex.mutex);
    while (!ex.done) {
      if (ex.cv.wait_for(lock, std::chrono::milliseconds(100), [&ex] { return ex.done; })) break;
      if (!exited && ::waitpid(pid, &exitStatus, WNOHANG) == pid) {
        exited = true;
        failure = "Chromium ended before the picture was drawn (" +
                  (WIFEXITED(exitStatus) ? "exit code " + std::to_string(WEXITSTATUS(exitStatus)) : "signal " + std::to_string(WTERMSIG(exitStatus))) +
                  "); its last lines:" + tail(log, 12);
        break;
      }
      if (std::chrono::steady_clock::now() > deadline) {
        failure = "the picture took longer than --timeout " + std::to_string(int(o.timeoutSeconds)) + " s; Chromium's last lines:" + tail(log, 12);
        break;
      }
    }
    if (failure.empty() && !ex.error.empty()) failure = ex.error;
  }
  if (spawned == 0) {
    ::kill(-pid, SIGKILL);  // the whole group: the main process and its renderer and GPU processes
    if (!exited) ::waitpid(pid, &exitStatus, 0);
    g_chromiumGroup = 0;
  }
  ::sigaction(SIGINT, &g_oldInt, nullptr);
  ::sigaction(SIGTERM, &g_oldTerm, nullptr);
  server.stop();
  serving.join();
  for (int attempt = 0; attempt < 50; ++attempt) {  // the group's last processes may still be leaving the profile
    fs::remove_all(profile, ec);
    if (!fs::exists(profile, ec)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (!failure.empty()) return internalError(what + ": " + failure);
  std::string png;
  {
    std::lock_guard<std::mutex> lock(ex.mutex);
    png = std::move(ex.png);
    report.pageTiming = ex.timing;
  }
  if (png.size() < 8 || png.compare(1, 3, "PNG") != 0) return internalError(what + ": the page sent no PNG");

  // 5. The file, whole or not at all.
  const fs::path out = fs::absolute(o.output);
  const fs::path tmp = out.string() + ".part";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f.write(png.data(), std::streamsize(png.size()));
    if (!f.flush()) {
      fs::remove(tmp, ec);
      return unavailable("cannot write " + tmp.string() + " (disk full?)");
    }
  }
  fs::rename(tmp, out, ec);
  if (ec) return unavailable("cannot write " + out.string() + ": " + ec.message());
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

}  // namespace pflow::display
