// Reads application/x-pflow-arrays (docs/viewer.md): frames of a little-endian u32 n, n bytes of JSON, then the
// frame's float32 values. The first frame is {step, time}; each other is one piece of an array (at most 1 MiB), a
// list of names ({strings}) or an error ({error, code}). The result holds whole arrays by section:
//   {step, time, particles: {name: Field}, grid: {spec, fields: {name: Field}} | null, geometry: {name: Field |
//    string[]} | null, probes: {name: Field} | null (time series: "time" and one per probe or DEM series)},
//   Field = {values: Float32Array(rows * components), rows, components, unit}.

export class ArraysError extends Error {
  constructor(message, code) {
    super(message);
    this.code = code || 'INTERNAL';
  }
}

const decoder = new TextDecoder();

export function parseArrays(buffer) {
  const bytes = new Uint8Array(buffer);
  const view = new DataView(buffer);
  const out = { step: 0, time: 0, particles: {}, grid: null, geometry: null, probes: null };
  let at = 0;
  let first = true;
  while (at < bytes.length) {
    if (at + 4 > bytes.length) throw new ArraysError('truncated frame length at byte ' + at);
    const n = view.getUint32(at, true);
    at += 4;
    if (at + n > bytes.length) throw new ArraysError('truncated frame header at byte ' + at);
    const header = JSON.parse(decoder.decode(bytes.subarray(at, at + n)));
    at += n;
    if (header.error !== undefined) throw new ArraysError(header.error, header.code);
    if (first) {
      out.step = header.step;
      out.time = header.time;
      first = false;
      continue;
    }
    if (header.strings) {  // names (geometry's surface and mesh names): no values follow
      out.geometry = out.geometry || {};
      out.geometry[header.name] = (out.geometry[header.name] || []).concat(header.strings);
      continue;
    }
    const components = header.components || 1;
    const count = header.rows * components;
    if (at + 4 * count > bytes.length) throw new ArraysError(`truncated values of '${header.name}'`);
    let table;
    if (header.section === 'grid') {
      out.grid = out.grid || { spec: null, fields: {} };
      if (header.grid) out.grid.spec = { origin: header.grid.origin, cellSize: header.grid.cell_size, cells: header.grid.cells };
      table = out.grid.fields;
    } else if (header.section === 'geometry') {
      table = out.geometry = out.geometry || {};
    } else if (header.section === 'particles') {
      table = out.particles;
    } else if (header.section === 'probes') {
      table = out.probes = out.probes || {};
    } else {
      at += 4 * count;  // a section this page does not know
      continue;
    }
    let field = table[header.name];
    if (!field) {
      field = { values: new Float32Array(header.total_rows * components), rows: header.total_rows, components, unit: header.unit || '' };
      table[header.name] = field;
    }
    // Byte copy: the values need not be 4-byte aligned in the stream.
    new Uint8Array(field.values.buffer).set(bytes.subarray(at, at + 4 * count), header.first_row * components * 4);
    at += 4 * count;
  }
  if (first) throw new ArraysError('empty answer: no snapshot header');
  return out;
}

export async function fetchArrays(url, headers = {}) {
  const response = await fetch(url, { headers });
  if (!response.ok) {
    let message = response.statusText, code = String(response.status);
    try {
      const body = await response.json();
      message = body.error || message;
      code = body.code || code;
    } catch (_) { /* not JSON */ }
    throw new ArraysError(message, code);
  }
  return parseArrays(await response.arrayBuffer());
}
