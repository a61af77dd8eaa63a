// Loads a bench report in headless Chromium (playwright-core) and fails unless every image
// decoded and every link and image resolves. Run by check-report.sh, which serves the folder.
// Usage: node check-report.cjs URL CHROMIUM
const { chromium } = require('playwright-core');

(async () => {
  const [url, executablePath] = process.argv.slice(2);
  const browser = await chromium.launch({ executablePath, args: ['--no-sandbox'] });
  const page = await browser.newPage();
  const failed = [];
  page.on('requestfailed', (r) => failed.push(`${r.url()}: ${r.failure().errorText}`));
  page.on('response', (r) => { if (r.status() >= 400) failed.push(`${r.url()}: HTTP ${r.status()}`); });
  const response = await page.goto(url, { waitUntil: 'load' });
  if (!response.ok()) failed.push(`${url}: HTTP ${response.status()}`);
  const images = await page.$$eval('img', (imgs) =>
    imgs.map((i) => ({ src: i.currentSrc, ok: i.complete && i.naturalWidth > 0, width: i.naturalWidth })));
  for (const i of images) if (!i.ok) failed.push(`${i.src}: image did not decode`);
  const links = await page.$$eval('a[href]', (as) => as.map((a) => a.href));
  for (const href of links) {
    const r = await page.request.get(href);
    if (!r.ok()) failed.push(`${href}: HTTP ${r.status()}`);
  }
  await browser.close();
  console.log(`${images.length} images, ${links.length} links checked in ${executablePath}`);
  if (failed.length > 0) {
    console.error(failed.join('\n'));
    process.exit(1);
  }
  console.log('all images decoded, all links resolve');
})().catch((e) => { console.error(e); process.exit(2); });
