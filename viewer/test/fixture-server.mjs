// A stand-in for `wellmesh serve` that serves one finished job from files, following the
// HTTP contract the viewer relies on (/jobs, /jobs/{id}, /jobs/{id}/results,
// /jobs/{id}/results/{output}, /viewer/...). For working on the viewer without the service.
//
// Usage: node viewer/test/fixture-server.mjs --glb FILE.glb --summary FILE.json
//          [--job ID] [--port N] [--running-polls N]
// Prints "listening http://127.0.0.1:PORT" once ready. The job reports `running` for the
// first --running-polls status requests (default 2), then `successful`.
import { createServer } from 'node:http';
import { readFile } from 'node:fs/promises';
import { dirname, extname, join, normalize, resolve, sep } from 'node:path';
import { fileURLToPath } from 'node:url';
import { parseArgs } from 'node:util';

const { values } = parseArgs({
  options: {
    glb: { type: 'string' },
    summary: { type: 'string' },
    job: { type: 'string', default: 'fixture' },
    port: { type: 'string', default: '0' },
    'running-polls': { type: 'string', default: '2' },
  },
});
if (!values.glb || !values.summary) {
  console.error('usage: fixture-server.mjs --glb FILE.glb --summary FILE.json [--job ID] [--port N]');
  process.exit(2);
}
const viewerDir = resolve(dirname(fileURLToPath(import.meta.url)), '..');
const glb = await readFile(values.glb);
const summary = JSON.parse(await readFile(values.summary, 'utf8'));
const job = values.job;
let runningPolls = Number(values['running-polls']);
const created = new Date().toISOString();

const TYPES = {
  '.html': 'text/html; charset=utf-8',
  '.js': 'text/javascript; charset=utf-8',
  '.mjs': 'text/javascript; charset=utf-8',
  '.css': 'text/css; charset=utf-8',
  '.json': 'application/json',
  '.png': 'image/png',
};

function statusInfo() {
  const running = runningPolls > 0;
  return {
    jobID: job,
    processID: 'dmt-contour',
    type: 'process',
    status: running ? 'running' : 'successful',
    message: running ? 'contour 0.5' : 'done',
    progress: running ? 50 : 100,
    created,
    started: created,
    finished: running ? null : created,
    updated: new Date().toISOString(),
    links: [],
  };
}

function send(res, status, type, body) {
  res.writeHead(status, { 'Content-Type': type, 'Cache-Control': 'no-store' });
  res.end(body);
}
const json = (res, status, value) => send(res, status, 'application/json', JSON.stringify(value));

const server = createServer(async (req, res) => {
  const url = new URL(req.url, 'http://localhost');
  const path = url.pathname;
  if (path === '/jobs') return json(res, 200, { jobs: [statusInfo()], links: [] });
  if (path === `/jobs/${job}`) {
    const info = statusInfo();
    if (runningPolls > 0) runningPolls -= 1;
    return json(res, 200, info);
  }
  if (path === `/jobs/${job}/results`) {
    if (runningPolls > 0) {
      return json(res, 404, {
        type: 'http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/result-not-ready',
        title: 'result not ready',
        status: 404,
        detail: `job ${job} is still running`,
      });
    }
    return json(res, 200, {
      summary,
      glb: { href: `/jobs/${job}/results/glb`, type: 'model/gltf-binary' },
    });
  }
  if (path === `/jobs/${job}/results/glb`) return send(res, 200, 'model/gltf-binary', glb);
  if (path === '/viewer' || path.startsWith('/viewer/')) {
    const relative = path === '/viewer' || path === '/viewer/' ? 'index.html' : decodeURIComponent(path.slice(8));
    const file = normalize(join(viewerDir, relative));
    if (!file.startsWith(viewerDir + sep)) return send(res, 400, 'text/plain', 'bad path');
    try {
      return send(res, 200, TYPES[extname(file)] ?? 'application/octet-stream', await readFile(file));
    } catch {
      return send(res, 404, 'text/plain', 'not found');
    }
  }
  return json(res, 404, { title: 'not found', status: 404 });
});
server.listen(Number(values.port), '127.0.0.1', () => {
  console.log(`listening http://127.0.0.1:${server.address().port}`);
});
