// Keeps a board's page live. Plain ES2017, no dependency; allowed by its hash in the page's
// Content-Security-Policy.
//
// It asks for the page again every few seconds with If-None-Match (an unchanged board answers
// 304 after one read), and at once when `drboard serve` streams a change; it swaps the
// standings in place and marks each arrival: a new entry, an improvement (with its rank
// movement) and a new leader (with a banner the room can read). On the big screen it scrolls
// each arrival into view and holds it there before scrolling on through a long board. A lost
// connection is said within a few seconds, and so is its return.
(() => {
  const main = document.querySelector("main[data-board]");
  if (!main || !window.fetch) return;
  const screen = main.classList.contains("screen");
  const HOLD_MS = parseFloat(getComputedStyle(document.documentElement)
    .getPropertyValue("--hold")) * 1000 || 8000;
  const FADE_MS = 2000, POLL_MS = 3000, STREAMED_POLL_MS = 15000, TIMEOUT_MS = 4000;
  const STREAM_SILENCE_MS = 4500;  // serve pings every 2 s: silence this long is a lost link
  const BANNER_MS = 8000, BACK_MS = 4000, SHOW_MS = 6000, MIN_SHOW_MS = 1500;
  const marks = new Map();  // racer -> {kind, since, move}
  const arrivals = [];      // racers to bring into view on the big screen, oldest first
  let etag = main.dataset.etag || null, busy = false, streamed = false, lost = false;
  let heard = Date.now(), holdUntil = 0, shownAt = 0, lastGood = new Date();

  const $ = (id) => document.getElementById(id);
  const rows = () => new Map([...main.querySelectorAll("tr[data-racer]")]
    .map((row) => [row.dataset.racer, row]));
  const say = (text) => { const el = $("live"); if (el) el.textContent = text; };
  const clock = (date) => date.toTimeString().slice(0, 8);

  function connection(ok) {
    const bar = $("connection");
    if (!bar) return;
    if (!ok && !lost) {
      lost = true;
      bar.className = "banner lost";
      bar.textContent = "Connection lost: retrying… (last update " + clock(lastGood) + ")";
      bar.hidden = false;
    } else if (ok && lost) {
      lost = false;
      bar.className = "banner back";
      bar.textContent = "Reconnected: the board is live again";
      bar.hidden = false;
      setTimeout(() => { if (!lost) bar.hidden = true; }, BACK_MS);
    }
  }

  function banner(text) {
    const el = $("leader-banner");
    if (!el) return;
    el.textContent = text;
    el.hidden = false;
    clearTimeout(banner.timer);
    banner.timer = setTimeout(() => { el.hidden = true; }, BANNER_MS);
  }

  function rankOf(row) { return parseInt(row.dataset.rank, 10); }

  async function refresh() {
    if (busy) return;
    busy = true;
    const abort = new AbortController();
    const timer = setTimeout(() => abort.abort(), TIMEOUT_MS);
    try {
      const answer = await fetch(location.pathname + location.search,
        { headers: etag ? { "If-None-Match": etag } : {}, cache: "no-store", signal: abort.signal });
      heard = Date.now();
      lastGood = new Date();
      connection(true);
      if (answer.status === 304) { say("Live"); return; }
      const next = new DOMParser().parseFromString(await answer.text(), "text/html")
        .querySelector("main[data-board]");
      if (!next) throw new Error("not a board page");
      apply(next, answer);
      say(answer.status === 404 ? "Waiting for the board's first push"
        : "Live");
      countdown();
    } catch (error) {
      connection(false);
      say("Reconnecting…");
    } finally {
      clearTimeout(timer);
      busy = false;
    }
  }

  function apply(next, answer) {
    const before = rows(), oldLeader = main.querySelector("tr[data-racer]");
    const hadEntries = before.size > 0 || main.dataset.missing === "1";
    const y = window.scrollY;
    main.innerHTML = next.innerHTML;
    main.dataset.missing = next.dataset.missing || "";
    etag = answer.headers.get("ETag") || next.dataset.etag || null;
    const now = Date.now(), after = rows();
    for (const [racer, row] of after) {
      const old = before.get(racer);
      if (!old && hadEntries) {
        marks.set(racer, { kind: "fresh", since: now, move: "new" });
        arrivals.push(racer);
      } else if (old && old.dataset.submission !== row.dataset.submission) {
        const up = rankOf(old) - rankOf(row);
        marks.set(racer, { kind: "improved", since: now,
          move: up > 0 ? "▲" + up : up < 0 ? "▼" + (-up) : "=" });
        arrivals.push(racer);
      }
    }
    // an arrival waiting cuts short the hold of the one before, once it has been seen a while
    if (arrivals.length) holdUntil = Math.min(holdUntil, shownAt + MIN_SHOW_MS);
    const top = main.querySelector("tr[data-racer]");
    if (top && oldLeader && top.dataset.racer !== oldLeader.dataset.racer) {
      const mark = marks.get(top.dataset.racer) || { since: now, move: "" };
      marks.set(top.dataset.racer, Object.assign(mark, { kind: "leader", since: now }));
      const time = top.querySelector("td.time");
      banner("New leader — " + top.dataset.racer + (time ? " " + time.textContent.trim() : ""));
    }
    // A mark outlives the refreshes that follow it: it goes on where it was.
    for (const [racer, mark] of marks) {
      const age = now - mark.since;
      if (age >= HOLD_MS + FADE_MS) { marks.delete(racer); continue; }
      const row = after.get(racer);
      if (!row) continue;
      row.classList.add(mark.kind);
      const move = row.querySelector("td.move");
      if (move && mark.move) {
        move.textContent = mark.move;
        move.setAttribute("aria-label", mark.move === "new" ? "new entry"
          : mark.move === "=" ? "improved, same rank" : (mark.move[0] === "▲" ? "up " : "down ")
            + mark.move.slice(1));
      }
      for (const cell of row.cells) cell.style.animationDelay = (HOLD_MS - age) + "ms";
      setTimeout(() => row.classList.add("faded"), HOLD_MS + FADE_MS - age);
    }
    if (!screen) window.scrollTo(0, y);
  }

  function countdown() {
    for (const el of main.querySelectorAll("[data-until]")) {
      let left = Math.max(0, Math.round((Date.parse(el.dataset.until) - Date.now()) / 1000));
      const parts = [];
      for (const [size, unit] of [[86400, "d"], [3600, "h"], [60, "min"], [1, "s"]]) {
        if (left >= size || (unit === "s" && !parts.length)) {
          parts.push(Math.floor(left / size) + " " + unit);
          left %= size;
        }
      }
      el.textContent = parts.slice(0, 2).join(" ");
      if (Date.parse(el.dataset.until) <= Date.now()) { delete el.dataset.until; refresh(); }
    }
  }

  function listen() {
    if (!window.EventSource) return;
    const stream = new EventSource(main.dataset.events);
    const alive = () => { heard = Date.now(); connection(true); };
    stream.addEventListener("board", () => { streamed = true; alive(); refresh(); });
    stream.addEventListener("ping", () => { streamed = true; alive(); });
    stream.onerror = () => {
      if (!streamed) { stream.close(); return; }  // no stream here (the cloud): poll instead
      connection(false);
      say("Reconnecting…");
    };
    setInterval(() => {
      if (streamed && Date.now() - heard > STREAM_SILENCE_MS) { connection(false); refresh(); }
    }, 1000);
  }

  function scroll() {
    // The big screen: each arrival brought into view and held; otherwise down through a long
    // board, a pause at each end, then back to the top.
    let pause = 200;
    setInterval(() => {
      const now = Date.now();
      if (now < holdUntil) return;
      while (arrivals.length) {
        const row = rows().get(arrivals.shift());
        if (!row) continue;
        const box = row.getBoundingClientRect();
        const head = main.querySelector("thead");
        const top = head ? head.getBoundingClientRect().bottom : 0;
        if (box.top < Math.max(top, 0) || box.bottom > window.innerHeight) {
          row.scrollIntoView({ block: "center" });
        }
        shownAt = now;
        holdUntil = now + (arrivals.length ? MIN_SHOW_MS : SHOW_MS);
        pause = 200;
        return;
      }
      const end = document.documentElement.scrollHeight - window.innerHeight;
      if (end <= 2) return;
      if (pause > 0) { pause -= 1; return; }
      if (window.scrollY >= end - 1) { window.scrollTo(0, 0); pause = 200; return; }
      window.scrollBy(0, 1);
      if (window.scrollY >= end - 1) pause = 200;
    }, 20);
  }

  (function tick() {
    refresh().finally(() => setTimeout(tick, streamed ? STREAMED_POLL_MS : POLL_MS));
  })();
  setInterval(countdown, 1000);
  listen();
  if (screen) scroll();
})();
