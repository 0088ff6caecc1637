// Starts the real myriad-server on a free loopback port and stops it with SIGTERM.

import {spawn} from 'node:child_process';
import net from 'node:net';

const START_TIMEOUT_MS = 120000;  // lavapipe with validation layers starts in seconds; be patient
const LOG_TAIL = 8000;

export async function startServer(path, args) {
  const child = spawn(path, args, {stdio: ['ignore', 'pipe', 'pipe']});
  let log = '';
  const keep = (chunk) => {
    log = (log + chunk.toString()).slice(-LOG_TAIL);
  };
  child.stderr.on('data', keep);

  const url = await new Promise((resolve, reject) => {
    let out = '';
    const timer = setTimeout(() => {
      child.kill('SIGKILL');
      reject(new Error(`myriad-server did not say where it listens within ${START_TIMEOUT_MS} ms:\n${log}`));
    }, START_TIMEOUT_MS);
    child.stdout.on('data', (chunk) => {
      out += chunk.toString();
      keep(chunk);
      const match = /listening on (http:\/\/\S+)/.exec(out);
      if (match) {
        clearTimeout(timer);
        resolve(match[1]);
      }
    });
    child.on('exit', (code, signal) => {
      clearTimeout(timer);
      reject(new Error(`myriad-server exited (${code ?? signal}) before listening:\n${log}`));
    });
  });

  return {
    url,
    log: () => log,
    // SIGTERM finishes the requests in flight; the exit status says whether that went cleanly.
    async stop() {
      if (child.exitCode !== null) return child.exitCode;
      const exited = new Promise((resolve) => child.on('exit', (code, signal) => resolve(code ?? signal)));
      child.kill('SIGTERM');
      const timer = setTimeout(() => child.kill('SIGKILL'), 30000);
      const status = await exited;
      clearTimeout(timer);
      return status;
    },
  };
}

// A TCP proxy on a free loopback port in front of `target` (http://host:port) that can break
// every connection it carries at once, as a dropped network or a proxy's timeout would.
export async function startCuttingProxy(target) {
  const {hostname, port} = new URL(target);
  const sockets = new Set();
  let connections = 0;
  const server = net.createServer((client) => {
    ++connections;
    const upstream = net.connect(Number(port), hostname);
    for (const [a, b] of [[client, upstream], [upstream, client]]) {
      sockets.add(a);
      a.on('close', () => {
        sockets.delete(a);
        b.destroy();
      });
      a.on('error', () => b.destroy());
    }
    client.pipe(upstream);
    upstream.pipe(client);
  });
  await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
  return {
    url: `http://127.0.0.1:${server.address().port}`,
    get connections() { return connections; },
    cutAll() {
      for (const socket of sockets) socket.destroy();
    },
    close() {
      this.cutAll();
      server.close();
    },
  };
}
