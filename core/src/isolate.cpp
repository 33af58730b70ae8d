// See isolate.h. POSIX fork + pipe: the child runs the reader and writes the mesh as raw arrays; the
// parent reads them while the child runs (so a large mesh cannot block on a full pipe), with a
// deadline, then reaps the child and decides from its exit status.
#include "isolate.h"

#include <cerrno>
#include <chrono>
#include <csignal>
#include <fcntl.h>
#include <cstdint>
#include <cstring>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <vector>

namespace fe {

namespace {

enum : std::int32_t { kOk = 0x4d455348, kInputError = 1, kOtherError = 2 };

bool write_all(int fd, const void* data, std::size_t n) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

template <class T>
bool put(int fd, const T& x) { return write_all(fd, &x, sizeof(T)); }

[[noreturn]] void child(int fd, const std::function<TriangleMesh()>& read) {
  std::int32_t status = kOtherError;
  std::string message;
  try {
    const TriangleMesh m = read();
    const std::uint64_t nv = static_cast<std::uint64_t>(m.vertices.rows()), nt = static_cast<std::uint64_t>(m.triangles.rows());
    const std::uint64_t nf = static_cast<std::uint64_t>(m.face_ids.size());
    const std::int32_t faces = m.num_faces;
    const std::uint64_t dropped = m.dropped_degenerate, reoriented = m.reoriented;
    const bool ok = put(fd, kOk) && put(fd, nv) && put(fd, nt) && put(fd, nf) && put(fd, faces) && put(fd, dropped) &&
                    put(fd, reoriented) && write_all(fd, m.vertices.data(), sizeof(double) * 3 * nv) &&
                    write_all(fd, m.triangles.data(), sizeof(int) * 3 * nt) && write_all(fd, m.face_ids.data(), sizeof(int) * nf);
    ::_exit(ok ? 0 : 3);
  } catch (const InputError& e) {
    status = kInputError;
    message = e.what();
  } catch (const std::exception& e) {
    message = e.what();
  } catch (...) {
    message = "unknown error";
  }
  const std::uint64_t len = message.size();
  const bool ok = put(fd, status) && put(fd, len) && write_all(fd, message.data(), message.size());
  ::_exit(ok ? 0 : 3);
}

struct Reader {
  const std::vector<char>& buf;
  std::size_t at = 0;
  bool get(void* out, std::size_t n) {
    if (buf.size() - at < n) return false;
    std::memcpy(out, buf.data() + at, n);
    at += n;
    return true;
  }
  template <class T>
  bool get(T& x) { return get(&x, sizeof(T)); }
};

}  // namespace

TriangleMesh read_isolated(const std::string& name, const std::function<TriangleMesh()>& read, double time_limit,
                           bool callers_limit) {
  int fds[2];
  if (::pipe(fds) != 0) throw InputError(name + ": cannot start the reader process: " + std::strerror(errno));
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw InputError(name + ": cannot start the reader process: " + std::strerror(errno));
  }
  if (pid == 0) {
    ::close(fds[0]);
    // The host's crash handlers (FreeCAD's, Python's faulthandler, OpenCASCADE's OSD::SetSignal) must
    // not run in the child: they print the host's traceback, and some exit() through the host's
    // static destructors. A fault simply ends the child; the parent reports it.
    for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGPIPE, SIGTERM, SIGINT}) ::signal(sig, SIG_DFL);
    // OpenCASCADE writes some complaints straight to std::cout ("File was not written with this
    // version of the topology"): the child's output goes nowhere; errors come back through the pipe.
    const int null = ::open("/dev/null", O_WRONLY);
    if (null >= 0) {
      ::dup2(null, 1);
      ::dup2(null, 2);
      ::close(null);
    }
    child(fds[1], read);
  }
  ::close(fds[1]);
  std::vector<char> buf;
  bool timed_out = false;
  const auto start = std::chrono::steady_clock::now();
  char chunk[1 << 16];
  for (;;) {
    int wait_ms = -1;
    if (time_limit > 0) {
      const double left = time_limit - std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (left <= 0) {
        timed_out = true;
        break;
      }
      wait_ms = static_cast<int>(std::min(left * 1000.0 + 1.0, 60000.0));
    }
    pollfd pf{fds[0], POLLIN, 0};
    const int r = ::poll(&pf, 1, wait_ms);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) break;
    if (r == 0) continue;  // deadline re-checked above
    const ssize_t n = ::read(fds[0], chunk, sizeof(chunk));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // end of data (the child exited or closed the pipe)
    buf.insert(buf.end(), chunk, chunk + n);
  }
  ::close(fds[0]);
  if (timed_out) ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timed_out && callers_limit)  // the caller's time limit, not a sign of a bad file
    throw TimeLimitExceeded(name + ": reading stopped by the time limit");
  if (timed_out)
    throw InputError(name + ": reading took longer than " + std::to_string(static_cast<long long>(time_limit)) +
                     " s and was stopped (a corrupt file, or raise the time limit)");
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    throw InputError(name + ": the reader crashed on this file (signal " + std::to_string(sig) + ", " +
                     (::strsignal(sig) ? ::strsignal(sig) : "?") + "): the file is corrupt or not supported");
  }
  Reader in{buf};
  std::int32_t kind = 0;
  if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0) || !in.get(kind))
    throw InputError(name + ": the reader process failed (exit status " + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")");
  if (kind != kOk) {
    std::uint64_t len = 0;
    std::string msg;
    if (in.get(len) && len <= buf.size()) {
      msg.resize(static_cast<std::size_t>(len));
      in.get(msg.data(), msg.size());
    }
    if (kind == kInputError) throw InputError(msg);
    throw InputError(name + ": " + msg);
  }
  std::uint64_t nv = 0, nt = 0, nf = 0, dropped = 0, reoriented = 0;
  std::int32_t faces = 0;
  TriangleMesh m;
  bool ok = in.get(nv) && in.get(nt) && in.get(nf) && in.get(faces) && in.get(dropped) && in.get(reoriented) &&
            nv <= buf.size() && nt <= buf.size() && nf <= buf.size();
  if (ok) {
    m.vertices.resize(static_cast<Eigen::Index>(nv), 3);
    m.triangles.resize(static_cast<Eigen::Index>(nt), 3);
    m.face_ids.resize(static_cast<Eigen::Index>(nf));
    ok = in.get(m.vertices.data(), sizeof(double) * 3 * nv) && in.get(m.triangles.data(), sizeof(int) * 3 * nt) &&
         in.get(m.face_ids.data(), sizeof(int) * nf);
  }
  if (!ok) throw InputError(name + ": the reader process returned a truncated mesh");
  m.num_faces = faces;
  m.dropped_degenerate = dropped;
  m.reoriented = reoriented;
  m.source = name;
  return m;
}

}  // namespace fe
