// `pflow render`: a snapshot as a PNG without a browser window, drawn by the web viewer's own code (web/src) in
// headless Chromium. The snapshot's arrays are served in the viewer's binary form (ArrayFrames.h) by a one-shot
// HTTP server on loopback whose paths carry a random key; the page draws, composes the picture with its title and
// colour bars, and posts the PNG back. Chromium runs with a fresh profile in a temporary folder, software WebGL
// (SwiftShader), and is killed when the picture arrives or the time runs out. docs/display.md.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/Status.h"
#include "display/ViewerSources.h"

namespace pflow::display {

struct RenderOptions {
  std::string output = "pflow.png";
  int width = 1600, height = 1000;           // pixels
  std::string view;                          // iso, top, front, side; "" = iso, or along the slice's axis
  std::string colorBy;                       // a particle field, speed, height, diameter, |vector|; "" = the page's default
  std::string colormap;                      // viridis, grey, coolwarm, inferno, categories; "" = by field
  std::optional<double> min, max;            // colour range; unset = the snapshot's
  std::string clip;                          // "AXIS=VALUE": what lies beyond VALUE (m) along AXIS is cut away
  std::string slice;                         // "AXIS=VALUE": a grid field on that slice
  std::string field;                         // the slice's grid field (default solid_fraction, or fluid_fraction)
  bool streamlines = false;                  // the in-plane mean velocity on the slice
  bool plot = false;                         // draw the run's time series as charts instead (`pflow plot`)
  std::vector<std::string> series;           // plot: the series to draw (names or prefixes); empty = all
  bool particles = true;                     // draw the particles (default: hidden when a slice is drawn)
  bool particlesSet = false;                 // `particles` was given
  std::string title;
  std::string chromium;                      // "" = $PFLOW_CHROMIUM, then chromium / chromium-browser / google-chrome on PATH
  std::string pageDir;                       // "" = $PFLOW_WEB_DIR, then <executable>/../web
  double timeoutSeconds = 120;
};

// Every problem of the options at once (one line each), or OK.
Status validateRenderOptions(const RenderOptions& options);

struct RenderReport {
  std::int64_t step = 0;
  double time = 0;
  std::uint64_t particles = 0;
  double seconds = 0;       // wall time, all of it
  std::string pageTiming;   // the page's own account (data, draw, png)
};

// Reads `request` from `source` (as `token`), draws it and writes options.output (via a temporary file beside it).
Result<RenderReport> renderSnapshot(const RenderOptions& options, SnapshotSource& source, const std::string& token,
                                    const SnapshotRequest& request);

// The Chromium executable, or NOT_FOUND with what to install.
Result<std::string> findChromium(const std::string& given);
// The folder holding render.html, or NOT_FOUND naming the places looked in.
Result<std::string> findPageDir(const std::string& given);

}  // namespace pflow::display
