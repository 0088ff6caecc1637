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

// In the page: the full-quality stream shows, at the size it asked for.
function fullQualityShown() {
  const img = document.getElementById('stream');
  const src = img.dataset.shown || '';  // the stream the shown part came from
  const q = new URLSearchParams(src.split('?')[1] || '');
  return src.includes('quality=90') && img.complete &&
         img.naturalWidth === Number(q.get('width')) && img.naturalHeight === Number(q.get('height'));
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
  await page.waitForFunction(fullQualityShown, null, {timeout: 120000, polling: 200});
  await page.waitForSelector('#stats-table tr[data-stat="GPU total"]', {timeout: 60000});
  // A slow orbit, so that the stats graph has a few frames in it.
  const view = await page.locator('#view').boundingBox();
  const [x, y] = [view.x + view.width / 2, view.y + view.height / 2];
  for (let i = 0; i < 6; ++i) {
    await page.mouse.move(x, y);
    await page.mouse.down();
    await page.mouse.move(x + 12, y, {steps: 3});
    await page.mouse.up();
    await page.waitForTimeout(1500);
  }
  await page.waitForFunction(fullQualityShown, null, {timeout: 120000, polling: 200});
  // Folded so that the light list and the stats fit beside the view in one window.
  await page.evaluate(() => {
    for (const summary of document.querySelectorAll('#panels summary')) {
      if (/^(Model|Material|Sun)/.test(summary.textContent)) summary.parentElement.open = false;
    }
  });
  await page.waitForTimeout(1500);  // a few stats samples in the graph
  await page.screenshot({path: output});
  console.log(`wrote ${output}`);
} finally {
  await browser.close();
  await server.stop();
}
