// Starts the real myriad-server on a free loopback port and stops it with SIGTERM.

import {spawn} from 'node:child_process';

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
