// A SnapshotSource over one snapshot file on this machine (backend/store/SnapshotFile.h: what `pflow run` writes
// and `pflow fetch` downloads), for `pflow render FILE.h5`. Grid fields come from the file when the back-end
// stored them, otherwise they are computed here with the back-end's own code (backend/fields/GridFields.h). The
// token and the job id of requests are ignored: whoever can read the file may draw it.
#pragma once
#include <memory>
#include <string>

#include "display/ViewerSources.h"

namespace pflow::display {

std::unique_ptr<SnapshotSource> makeFileSnapshotSource(const std::string& h5Path, double gridCellSize = 0);

}  // namespace pflow::display
