// Bundles the page (src/app.js) and `pflow render`'s page (src/render.js) with three.js into OUT (default dist/),
// and copies the static files. Run by the CMake target `web` (web/CMakeLists.txt); no network, no CDN at run time.
import { build } from 'esbuild';
import { cpSync, mkdirSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const out = process.argv[2] || join(here, 'dist');
mkdirSync(out, { recursive: true });
await build({
  entryPoints: { app: join(here, 'src/app.js'), render: join(here, 'src/render.js') },
  bundle: true,
  format: 'iife',
  target: ['chrome110', 'firefox110', 'safari16'],
  minify: true,
  sourcemap: true,
  outdir: out,
  logLevel: 'warning',
});
cpSync(join(here, 'page'), out, { recursive: true });
