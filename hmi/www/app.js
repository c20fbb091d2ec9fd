// The operator screen: one WebSocket brings the layout and ~10 status messages a second
// (docs/hmi.md, "Data protocol"); commands go back over the same socket and the server
// accepts them only from a logged-in session. No framework, no build step.
'use strict';

const SVG_NS = 'http://www.w3.org/2000/svg';
const WIDTH = 1200;
const BELT_Y = 130;           // centre line of the product path in the drawing
const MM_PER_PX_Y = 3.5;      // lateral scale: the belts are about 400 mm wide
const BELT_HALF_WIDTH_MM = 200;

const state = {
  socket: null,
  layout: null,
  authenticated: false,
  twin: false,
  lastStatus: null,
  nextId: 1,
  pending: new Map(),
  scale: null,
};
window.hmi = state;  // for the browser console and the end-to-end test

const $ = (id) => document.getElementById(id);

function showMessage(text, isError = false) {
  const message = $('message');
  message.textContent = text;
  message.className = isError ? 'error' : '';
}

function svg(tag, attributes = {}, parent = null) {
  const element = document.createElementNS(SVG_NS, tag);
  for (const [key, value] of Object.entries(attributes)) element.setAttribute(key, value);
  if (parent) parent.appendChild(element);
  return element;
}

function fmt(value, digits = 2) {
  return value === null || value === undefined ? '–' : Number(value).toFixed(digits);
}

// ---------------------------------------------------------------- layout

function drawLayout(layout) {
  state.layout = layout;
  const start = -layout.takt_belt_length_mm;
  const end = layout.placed_at_s_mm;
  const pxPerMm = (WIDTH - 20) / (end - start);
  state.scale = {
    pxPerMm,
    x: (s) => 10 + (s - start) * pxPerMm,
    y: (y) => BELT_Y - y / MM_PER_PX_Y,  // positive y is left looking downstream: up
  };
  const { x, y } = state.scale;
  const belts = $('belts');
  const stations = $('stations');
  belts.replaceChildren();
  stations.replaceChildren();
  const beltTop = y(BELT_HALF_WIDTH_MM);
  const beltHeight = y(-BELT_HALF_WIDTH_MM) - beltTop;
  // The takt belt has no section of its own: it ends at the barrier, s = 0.
  const sections = [{ drive: 'takt', start_mm: start, end_mm: 0 }, ...layout.sections];
  for (const section of sections) {
    const group = svg('g', { class: 'belt', 'data-drive': section.drive }, belts);
    svg('rect', {
      x: x(section.start_mm), y: beltTop, width: x(section.end_mm) - x(section.start_mm),
      height: beltHeight,
    }, group);
    const label = svg('text', {
      x: (x(section.start_mm) + x(section.end_mm)) / 2, y: beltTop - 18, class: 'belt-name',
    }, group);
    label.textContent = section.drive.replace('_left', '');
    svg('text', {
      x: (x(section.start_mm) + x(section.end_mm)) / 2, y: beltTop - 5, class: 'belt-speed',
      id: `speed-${section.drive}`,
    }, group);
  }
  for (const camera of layout.cameras) {
    const cx = x(camera.s_mm);
    svg('path', { d: `M${cx - 6},${beltTop - 36} L${cx + 6},${beltTop - 36} L${cx},${beltTop - 26} Z`,
      class: 'camera' }, stations).appendChild(titled(`camera ${camera.name}`));
  }
  const s = layout.stations;
  const plate = (id, at, name) => {
    svg('rect', { id, x: x(at) - 4, y: beltTop, width: 8, height: beltHeight, class: 'plate' },
      stations).appendChild(titled(name));
  };
  plate('plate1', s.flip_plate1_s_mm, 'flip plate 1 (end over end)');
  plate('plate2', s.flip_plate2_s_mm, 'flip plate 2 (sideways)');
  svg('rect', { id: 'centring', x: x(s.centring_s_mm) - 3, y: beltTop - 8, width: 6, height: 8,
    class: 'actuator' }, stations).appendChild(titled('centring unit'));
  svg('rect', { id: 'roller', x: x(s.squeeze_roller_s_mm) - 4, y: beltTop - 10, width: 8,
    height: 10, class: 'actuator' }, stations).appendChild(titled('squeeze roller'));
  svg('path', { id: 'knife', d: `M${x(s.final_reject_s_mm)},${beltTop + beltHeight + 4} l-6,12 h12 Z`,
    class: 'actuator' }, stations).appendChild(titled('final air knife'));
  const reject = layout.sections.find((section) => section.drive === 'reject');
  if (reject) {
    const arrow = svg('text', { id: 'reject-arrow', x: (x(reject.start_mm) + x(reject.end_mm)) / 2,
      y: beltTop + beltHeight + 16, class: 'reject-arrow' }, stations);
    arrow.textContent = '→';
  }
  const target = $('twin-target');
  target.replaceChildren();
}

function titled(text) {
  const title = document.createElementNS(SVG_NS, 'title');
  title.textContent = text;
  return title;
}

// ---------------------------------------------------------------- status

function render(status) {
  state.lastStatus = status;
  const badge = $('line-state');
  badge.textContent = status.state;
  badge.className = `badge state-${status.state}`;
  renderFillets(status.fillets);
  renderFaults(status.faults, status.estop_ok);
  renderDrives(status.drives);
  renderActuators(status.actuators);
  renderKpis(status.kpis);
  renderTiming(status.timing);
  updateButtons();
}

function renderFillets(fillets) {
  if (!state.scale) return;
  const { x, y } = state.scale;
  const group = $('fillets');
  const existing = new Map([...group.children].map((node) => [node.dataset.id, node]));
  for (const fillet of fillets) {
    const id = String(fillet.id);
    let node = existing.get(id);
    if (!node) {
      node = svg('g', { 'data-id': id, class: 'fillet' }, group);
      // About a fillet's size: 170 mm long, 70 mm wide.
      svg('ellipse', { rx: (85 * state.scale.pxPerMm).toFixed(1), ry: (35 / MM_PER_PX_Y).toFixed(1) }, node);
      svg('title', {}, node);
    }
    existing.delete(id);
    const angle = fillet.angle_rad === null ? 0 : -fillet.angle_rad * 180 / Math.PI;
    node.setAttribute('transform', `translate(${x(fillet.s_mm).toFixed(1)},${y(fillet.y_mm).toFixed(1)}) rotate(${angle.toFixed(0)})`);
    node.dataset.s = fillet.s_mm.toFixed(1);
    node.setAttribute('class', `fillet ${fillet.state}`);
    node.querySelector('title').textContent =
      `#${fillet.id} ${fillet.state}${fillet.reject_reason ? ` (${fillet.reject_reason})` : ''}` +
      `, ${fillet.hand} hand, ${fillet.side} up, s ${fillet.s_mm.toFixed(0)} mm` +
      (fillet.lane ? `, orienting unit ${fillet.lane}` : '');
  }
  for (const node of existing.values()) node.remove();
  $('fillet-count').textContent = `${fillets.length} fillet${fillets.length === 1 ? '' : 's'} tracked`;
}

function renderFaults(faults, estopOk) {
  const list = $('faults');
  list.replaceChildren();
  const all = estopOk ? faults : [...new Set(['E-stop chain open', ...faults])];
  if (all.length === 0) {
    const none = document.createElement('li');
    none.className = 'none';
    none.textContent = 'none';
    list.appendChild(none);
  }
  for (const fault of all) {
    const item = document.createElement('li');
    item.className = 'fault';
    item.textContent = fault.replaceAll('_', ' ');
    list.appendChild(item);
  }
}

function renderDrives(drives) {
  const body = document.querySelector('#drives tbody');
  body.replaceChildren();
  // In flow order, as the layout names them (JSON objects carry no order).
  const names = state.layout?.drives ?? Object.keys(drives);
  for (const name of names) {
    const drive = drives[name];
    if (!drive) continue;
    const row = body.insertRow();
    row.insertCell().textContent = name;
    row.insertCell().textContent = fmt(drive.command_mps);
    row.insertCell().textContent = fmt(drive.speed_mps);
    const condition = drive.fault ? 'fault' : !drive.enabled ? 'off' : drive.ready ? 'ready' : 'not ready';
    const cell = row.insertCell();
    cell.textContent = condition;
    cell.className = `drive-${condition.replace(' ', '-')}`;
    const label = document.getElementById(`speed-${name}`);
    if (label) label.textContent = `${fmt(drive.speed_mps)} m/s`;
  }
}

function renderActuators(a) {
  figures($('actuators'), [
    ['flip plate 1', a.flip_plate1.flipping ? 'retracted (flips)' : 'closed'],
    ['flip plate 2', a.flip_plate2.flipping ? 'retracted (flips)' : 'closed'],
    ['reject belt', a.reject_reversing ? 'reversing into the crate' : 'forward'],
    ['final air knife', a.final_reject ? 'blowing' : 'off'],
    ['centring', a.centring_stroke ? `stroke ${fmt(a.centring_shift_mm, 0)} mm` : 'parked'],
    ['squeeze roller', a.squeeze_roller_down ? 'down' : 'up'],
    ['layer height', `${fmt(a.level_mm, 0)} mm`],
    ['hopper opening', `${fmt(a.hopper_opening_mm, 0)} mm`],
    ['leveller', `${fmt(a.leveller_speed_rpm, 0)} rpm`],
  ]);
  const plate = (id, on) => $(id)?.setAttribute('class', on ? 'plate open' : 'plate');
  plate('plate1', a.flip_plate1.flipping);
  plate('plate2', a.flip_plate2.flipping);
  $('centring')?.setAttribute('class', a.centring_stroke ? 'actuator active' : 'actuator');
  $('roller')?.setAttribute('class', a.squeeze_roller_down ? 'actuator active' : 'actuator');
  $('knife')?.setAttribute('class', a.final_reject ? 'actuator active' : 'actuator');
  const arrow = $('reject-arrow');
  if (arrow) {
    arrow.textContent = a.reject_reversing ? '← into crate' : '→';
    arrow.setAttribute('class', a.reject_reversing ? 'reject-arrow reversing' : 'reject-arrow');
  }
}

function renderKpis(k) {
  $('kpi-throughput').textContent =
    k.placed_per_min === null ? 'measuring…' : `${fmt(k.placed_per_min, 1)} placed / min`;
  $('kpi-placed').textContent = String(k.placed);
  $('kpi-share').textContent = k.placed_share === null ? '–' : `${fmt(100 * k.placed_share, 1)} %`;
  const rows = Object.entries(k.outcomes).map(([outcome, count]) => [outcome, String(count)]);
  rows.push(['adopted (unknown to the takt)', String(k.items_adopted)]);
  rows.push(['estimates rejected', String(k.estimates_rejected)]);
  if (k.records_dropped > 0) rows.push(['ledger records LOST', String(k.records_dropped)]);
  figures($('outcomes'), rows);
}

function renderTiming(t) {
  figures($('timing'), [
    ['period', `${fmt(t.period_ms, 1)} ms`],
    ['wake-up jitter, last / max 1 s / max', `${fmt(t.wakeup_latency_ms, 3)} / ${fmt(t.window_max_wakeup_latency_ms, 3)} / ${fmt(t.max_wakeup_latency_ms, 3)} ms`],
    ['compute, last / max 1 s / max', `${fmt(t.compute_ms, 3)} / ${fmt(t.window_max_compute_ms, 3)} / ${fmt(t.max_compute_ms, 3)} ms`],
    ['scans', String(t.scans)],
    ['overruns', String(t.overruns)],
  ]);
}

function figures(table, rows) {
  table.replaceChildren();
  for (const [name, value] of rows) {
    const row = table.insertRow();
    const header = document.createElement('th');
    header.textContent = name;
    row.appendChild(header);
    row.insertCell().textContent = value;
  }
}

// ---------------------------------------------------------------- session and commands

function updateButtons() {
  const auth = state.authenticated;
  const lineState = state.lastStatus?.state;
  // The controller takes a start only when stopped, a stop only when starting or running.
  $('start-button').disabled = !auth || lineState !== 'stopped';
  $('stop-button').disabled = !auth || !(lineState === 'running' || lineState === 'starting');
  $('ack-button').disabled = !auth || !(state.lastStatus?.faults.length > 0);
  $('twin-raise').disabled = !auth;
  $('twin-clear').disabled = !auth;
  $('auth-hint').hidden = auth;
  $('login-form').hidden = auth;
  $('session').hidden = !auth;
}

function setSession(session) {
  state.authenticated = session.authenticated;
  state.twin = session.twin;
  $('session-user').textContent = session.user ?? '';
  $('twin-panel').hidden = !session.twin;
  if (!session.logins_enabled && session.logins_enabled !== undefined) {
    $('auth-hint').textContent = 'Read-only: no operator password is configured (docs/hmi.md).';
  }
  updateButtons();
}

async function refreshSession() {
  const response = await fetch('/api/session', { cache: 'no-store' });
  setSession(await response.json());
}

function send(message) {
  return new Promise((resolve) => {
    if (!state.socket || state.socket.readyState !== WebSocket.OPEN) {
      resolve({ ok: false, error: 'not connected' });
      return;
    }
    const id = state.nextId++;
    state.pending.set(id, resolve);
    state.socket.send(JSON.stringify({ ...message, id }));
  });
}

async function command(name) {
  const result = await send({ type: 'command', command: name });
  showMessage(result.ok ? `${name}: sent` : `${name} refused: ${result.error}`, !result.ok);
  if (!result.ok && result.error === 'log in first') refreshSession();
}

function confirmThen(text, action) {
  const dialog = $('confirm');
  $('confirm-text').textContent = text;
  dialog.returnValue = '';
  dialog.onclose = () => { if (dialog.returnValue === 'ok') action(); };
  dialog.showModal();
}

async function login(event) {
  event.preventDefault();
  const response = await fetch('/api/login', {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify({ user: $('login-user').value, password: $('login-password').value }),
  });
  const body = await response.json();
  $('login-password').value = '';
  if (!response.ok) {
    showMessage(`login failed: ${body.error}`, true);
    return;
  }
  showMessage(`logged in as ${body.user}`);
  await refreshSession();
  connect();  // the new socket carries the session cookie
}

async function logout() {
  await fetch('/api/logout', {
    method: 'POST', headers: { 'Content-Type': 'application/json' }, body: '{}',
  });
  showMessage('logged out');
  await refreshSession();
  connect();
}

function fillTwinTargets() {
  const fault = $('twin-fault').value;
  const target = $('twin-target');
  target.replaceChildren();
  const names = fault === 'camera_silent' ? state.layout?.camera_names ?? []
    : fault === 'drive_lost' ? state.layout?.drives ?? [] : ['line'];
  for (const name of names) target.add(new Option(name, name));
  if (fault === 'drive_lost') target.value = 'guide';
}

async function twinFault(active) {
  const result = await send({
    type: 'twin_fault', fault: $('twin-fault').value, target: $('twin-target').value, active,
  });
  showMessage(result.ok ? `twin fault ${active ? 'raised' : 'cleared'}` : `twin: ${result.error}`,
    !result.ok);
}

// ---------------------------------------------------------------- connection

function connect() {
  if (state.socket) {
    state.socket.onclose = null;
    state.socket.close();
  }
  const scheme = location.protocol === 'https:' ? 'wss' : 'ws';
  const socket = new WebSocket(`${scheme}://${location.host}/ws`);
  state.socket = socket;
  const connection = $('connection');
  socket.onopen = () => {
    connection.textContent = 'live';
    connection.className = 'connection up';
  };
  socket.onclose = () => {
    connection.textContent = 'disconnected, retrying…';
    connection.className = 'connection down';
    for (const resolve of state.pending.values()) resolve({ ok: false, error: 'disconnected' });
    state.pending.clear();
    setTimeout(connect, 2000);
  };
  socket.onmessage = (event) => {
    const message = JSON.parse(event.data);
    switch (message.type) {
      case 'hello':
        setSession({ ...message, logins_enabled: undefined });
        break;
      case 'layout':
        drawLayout(message);
        fillTwinTargets();
        break;
      case 'status':
        render(message);
        break;
      case 'command_result': {
        const resolve = state.pending.get(message.id);
        state.pending.delete(message.id);
        if (resolve) resolve(message);
        break;
      }
      default:
        break;
    }
  };
}

document.addEventListener('DOMContentLoaded', () => {
  $('login-form').addEventListener('submit', login);
  $('logout-button').addEventListener('click', logout);
  $('start-button').addEventListener('click',
    () => confirmThen('Start the line? Belts and the takt will run.', () => command('start')));
  $('stop-button').addEventListener('click',
    () => confirmThen('Stop the line? The infeed stops and the belts drain.', () => command('stop')));
  $('ack-button').addEventListener('click', () => command('acknowledge'));
  $('twin-fault').addEventListener('change', fillTwinTargets);
  $('twin-raise').addEventListener('click', () => twinFault(true));
  $('twin-clear').addEventListener('click', () => twinFault(false));
  refreshSession().catch(() => {});
  connect();
});
