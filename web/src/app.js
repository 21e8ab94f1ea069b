// The viewer's page: sign in with a pflow token, the jobs (live), the nodes, and a job's 3-D view. Routes are the
// URL's hash: #jobs, #nodes, #job/ID.
import { api, token, el } from './api.js';
import { JobsTable, renderNodes } from './jobs.js';
import { JobView } from './jobview.js';

const main = document.getElementById('main');
const who = document.getElementById('who');
let jobs = null, view = null, timer = null;
let routed = 0;  // counts stops: a route that awaited its first poll goes on only if nothing stopped it meanwhile

function stop() {
  ++routed;
  if (timer) clearInterval(timer);
  timer = null;
  if (jobs) jobs.close();
  if (view) view.close();
  jobs = view = null;
}

function showLogin(message = '') {
  stop();
  who.replaceChildren();
  const input = el('input', { id: 'token', type: 'password', placeholder: 'pflow_…', autocomplete: 'off', size: 48 });
  const error = el('div', { class: 'error', id: 'login-error' }, message);
  const submit = async (e) => {
    e.preventDefault();
    token.set(input.value.trim());
    try {
      await api.jobs(false);
      route();
    } catch (err) {
      token.clear();
      error.textContent = err.status === 401 || err.status === 403 ? `token refused: ${err.message}` : err.message;
    }
  };
  main.replaceChildren(el('form', { id: 'login', class: 'login', onsubmit: submit },
    el('h2', {}, 'Sign in'),
    el('p', {}, 'Your pflow token (the one the CLI uses: PFLOW_TOKEN or token: in its config file). It stays in this tab only.'),
    input, el('button', { type: 'submit', id: 'login-button' }, 'sign in'), error));
  input.focus();
}

function header() {
  who.replaceChildren(el('button', { id: 'sign-out', onclick: () => { token.clear(); showLogin(); } }, 'sign out'));
}

function onAuthError(e) {
  if (e && (e.status === 401 || e.status === 403)) showLogin(`signed out: ${e.message}`);
}

async function route() {
  stop();
  const mine = routed;
  if (!token.get()) return showLogin();
  header();
  const hash = location.hash || '#jobs';
  for (const a of document.querySelectorAll('nav a')) a.classList.toggle('active', hash.startsWith(a.getAttribute('href')));
  if (hash.startsWith('#job/')) {
    view = new JobView(main, decodeURIComponent(hash.slice(5)));
    return;
  }
  if (hash === '#nodes') {
    const box = el('div', { id: 'nodes' });
    const error = el('div', { class: 'error' });
    main.replaceChildren(error, box);
    const poll = () => renderNodes(box).then(() => (error.textContent = '')).catch((e) => { error.textContent = `nodes: ${e.message}`; onAuthError(e); });
    await poll();
    if (mine === routed) timer = setInterval(poll, 5000);
    return;
  }
  const box = el('div', { id: 'jobs' });
  main.replaceChildren(box);
  // The poll holds its own table: a later route (a click while the first poll is in flight) stops this one's.
  const table = new JobsTable(box, { onOpen: (id) => { location.hash = `#job/${encodeURIComponent(id)}`; } });
  jobs = table;
  const poll = () => table.refresh().catch(onAuthError);
  await poll();
  if (mine === routed) timer = setInterval(poll, 3000);
}

window.addEventListener('hashchange', route);
route();
