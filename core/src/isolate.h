// Reading a file in a child process (issue 10). OpenCASCADE's STEP, IGES and BREP readers can crash
// (a null dereference on a dangling entity) or never return on a corrupt file, and no signal guard
// makes that safe in-process: inside FreeCAD it would kill FreeCAD with the user's unsaved work. The
// read runs in a forked child instead; its mesh comes back through a pipe. A crash, a hang past the
// time limit or an exception in the child becomes an InputError naming the file, in the caller.
#pragma once

#include "featureextract/mesh.h"

#include <functional>
#include <string>

namespace fe {

/// Runs `read` in a child process and returns its mesh. `time_limit` (seconds, > 0) bounds the child;
/// 0 means no limit. Throws InputError("name: ...") when the child fails, crashes or is stopped.
TriangleMesh read_isolated(const std::string& name, const std::function<TriangleMesh()>& read, double time_limit,
                           bool callers_limit = false);

}  // namespace fe
