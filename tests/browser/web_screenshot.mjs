// Takes the README's picture of the web client: the real server, the page in headless Chromium,
// a screenshot once the full-quality stream and the stats are showing.
// Usage: node web_screenshot.mjs <myriad-server> <output.png> [server flags...]

import {chromium} from 'playwright-core';
import {startServer} from './server_process.mjs';

const [serverPath, output, ...flags] = process.argv.slice(2);
if (!serverPath || !output) {
  console.error('usage: node web_screenshot.mjs <myriad-server> <output.png> [server flags...]');
  process.exit(2);
}

const server = await startServer(serverPath, ['--port', '0', ...flags]);
const browser = await chromium.launch({
  executablePath: '/usr/bin/chromium',
  args: ['--headless', '--no-sandbox', '--disable-gpu'],
});
try {
  const page = await browser.newPage({viewport: {width: 1280, height: 720}});
  await page.goto(`${server.url}/`);
  // The full-quality stream at the size it asked for, and at least one frame's pass times.
  await page.waitForFunction(() => {
    const img = document.getElementById('stream');
    const src = img.getAttribute('src') || '';
    const q = new URLSearchParams(src.split('?')[1] || '');
    return src.includes('quality=90') && img.complete &&
           img.naturalWidth === Number(q.get('width')) && img.naturalHeight === Number(q.get('height'));
  }, null, {timeout: 120000, polling: 200});
  await page.waitForSelector('#stats-table tr[data-stat="GPU total"]', {timeout: 60000});
  await page.waitForTimeout(1500);  // a few stats samples in the graph
  await page.screenshot({path: output});
  console.log(`wrote ${output}`);
} finally {
  await browser.close();
  await server.stop();
}
