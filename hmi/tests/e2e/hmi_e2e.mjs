// The operator HMI end to end in headless Chromium, against `linectl run --realtime --hmi`
// on the fast plant (run_e2e.sh starts it):
//   node hmi_e2e.mjs BASE_URL USER PASSWORD WORK_DIR
// Loads the page, sees fillets move, checks that commands without a login are refused over
// HTTP and WebSocket, raises a camera fault in the twin and sees it shown, logs in,
// acknowledges it and sees it cleared, and stops and restarts the line through the
// confirmation dialog.
import assert from 'node:assert/strict';
import { chromium } from 'playwright-core';

const [baseUrl, user, password, workDir] = process.argv.slice(2);
if (!baseUrl || !user || !password) {
  console.error('usage: node hmi_e2e.mjs BASE_URL USER PASSWORD [WORK_DIR]');
  process.exit(2);
}

function step(text) {
  console.log(`== ${text}`);
}

async function waitForServer() {
  const deadline = Date.now() + 30_000;
  while (Date.now() < deadline) {
    try {
      const response = await fetch(`${baseUrl}/api/session`);
      if (response.ok) return;
    } catch {
      // not listening yet
    }
    await new Promise((resolve) => setTimeout(resolve, 200));
  }
  throw new Error(`no HMI at ${baseUrl} within 30 s`);
}

// The twin's fault switches, through the HMI's API with a session of our own (the page
// under test stays logged out until the test logs it in).
async function twinFault(active) {
  const login = await fetch(`${baseUrl}/api/login`, {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify({ user, password }),
  });
  assert.equal(login.status, 200, 'the test session logs in');
  const cookie = login.headers.get('set-cookie').split(';')[0];
  const response = await fetch(`${baseUrl}/api/twin/fault`, {
    method: 'POST',
    headers: { 'Content-Type': 'application/json', Cookie: cookie },
    body: JSON.stringify({ fault: 'camera_silent', target: 'orientation', active }),
  });
  assert.equal(response.status, 200, `twin fault ${active ? 'raised' : 'cleared'}`);
}

async function filletPositions(page) {
  return page.$$eval('#fillets [data-id]', (nodes) =>
    Object.fromEntries(nodes.map((node) => [node.dataset.id, Number(node.dataset.s)])));
}

async function lineState(page) {
  return page.textContent('#line-state');
}

async function confirmDialog(page, button, choice) {
  await page.click(button);
  await page.waitForSelector('#confirm[open]');
  await page.click(choice === 'ok' ? '#confirm-ok' : '#confirm-cancel');
  await page.waitForSelector('#confirm:not([open])', { state: 'attached' });
}

await waitForServer();
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
  headless: true,
  args: ['--no-sandbox', '--disable-dev-shm-usage', '--disable-gpu'],
});
let page;
try {
  page = await browser.newPage();
  const pageErrors = [];
  page.on('pageerror', (error) => pageErrors.push(String(error)));

  step('the page loads and goes live');
  await page.goto(baseUrl);
  await page.waitForSelector('#connection.up', { timeout: 15_000 });
  await page.waitForSelector('#belts .belt', { timeout: 15_000 });

  step('fillets move');
  await page.waitForFunction(
    () => document.querySelectorAll('#fillets [data-id]').length > 0, null, { timeout: 30_000 });
  const first = await filletPositions(page);
  await page.waitForTimeout(1000);
  const second = await filletPositions(page);
  const moved = Object.keys(first).filter((id) => id in second && second[id] > first[id] + 10);
  assert.ok(moved.length > 0,
    `some fillet moved downstream: ${JSON.stringify(first)} then ${JSON.stringify(second)}`);
  assert.match(await lineState(page), /running|starting/);
  if (workDir) await page.screenshot({ path: `${workDir}/hmi.png`, fullPage: true });

  step('without a login every command is refused');
  assert.equal(await page.isDisabled('#start-button'), true);
  assert.equal(await page.isDisabled('#stop-button'), true);
  const httpStatus = await page.evaluate(async () => {
    const response = await fetch('/api/command', {
      method: 'POST',
      headers: { 'Content-Type': 'application/json' },
      body: JSON.stringify({ command: 'stop' }),
    });
    return response.status;
  });
  assert.equal(httpStatus, 401, 'HTTP command without a session');
  const wsReply = await page.evaluate(() => new Promise((resolve, reject) => {
    const socket = new WebSocket(`ws://${location.host}/ws`);
    socket.onopen = () => socket.send(JSON.stringify({ type: 'command', id: 99, command: 'stop' }));
    socket.onmessage = (event) => {
      const message = JSON.parse(event.data);
      if (message.type === 'command_result') {
        socket.close();
        resolve(message);
      }
    };
    socket.onerror = () => reject(new Error('WebSocket error'));
  }));
  assert.equal(wsReply.ok, false, 'WebSocket command without a session');
  assert.equal(wsReply.error, 'log in first');
  await page.waitForTimeout(300);
  assert.match(await lineState(page), /running|starting/, 'the refused stop did not stop the line');

  step('a camera fault raised in the twin shows');
  await twinFault(true);
  await page.waitForSelector('#faults li.fault:has-text("camera silent")', { timeout: 10_000 });
  await twinFault(false);
  await page.waitForTimeout(500);
  assert.ok(await page.isVisible('#faults li.fault:has-text("camera silent")'),
    'the fault stays latched until acknowledged');
  assert.equal(await page.isDisabled('#ack-button'), true, 'no acknowledge without a login');

  step('the operator logs in and acknowledges');
  await page.fill('#login-user', user);
  await page.fill('#login-password', 'not the password');
  await page.click('#login-button');
  await page.waitForSelector('#message.error:has-text("login failed")');
  await page.fill('#login-password', password);
  await page.click('#login-button');
  await page.waitForSelector('#session:not([hidden])');
  await page.waitForSelector('#ack-button:not([disabled])', { timeout: 10_000 });
  await page.click('#ack-button');
  await page.waitForSelector('#faults li.none', { timeout: 10_000 });

  step('stop asks for confirmation; cancel keeps the line running');
  await page.waitForSelector('#stop-button:not([disabled])');
  await confirmDialog(page, '#stop-button', 'cancel');
  await page.waitForTimeout(500);
  assert.match(await lineState(page), /running|starting/);
  await confirmDialog(page, '#stop-button', 'ok');
  await page.waitForFunction(
    () => /stopping|stopped/.test(document.querySelector('#line-state').textContent), null,
    { timeout: 10_000 });

  step('start after confirmation');
  await page.waitForSelector('#start-button:not([disabled])', { timeout: 60_000 });
  await confirmDialog(page, '#start-button', 'ok');
  await page.waitForFunction(
    () => /starting|running/.test(document.querySelector('#line-state').textContent), null,
    { timeout: 10_000 });

  step('after logging out the controls lock again');
  await page.click('#logout-button');
  await page.waitForSelector('#login-form:not([hidden])');
  assert.equal(await page.isDisabled('#stop-button'), true);

  assert.deepEqual(pageErrors, [], 'no script errors on the page');
  console.log('hmi e2e: all steps passed');
} catch (error) {
  if (page && workDir) {
    await page.screenshot({ path: `${workDir}/failure.png`, fullPage: true }).catch(() => {});
    console.error(`screenshot: ${workDir}/failure.png`);
  }
  throw error;
} finally {
  await browser.close();
}
