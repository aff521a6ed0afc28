// Two-way audio card (Drive page and dashboard): Listen plays the robot's microphone, holding
// Talk (or the T key) sends this computer's microphone to the robot's speakers.
//
// Listening: the server relays the robot's microphone as binary websocket frames of S16LE PCM,
// whatever the robot sends (it decodes mp3 itself: robot/audio/mic.py says why), after a
// "format" frame with the rate and channels. Chunks become AudioBuffers scheduled back to back
// on the AudioContext clock behind a small jitter buffer. Anything that cannot be played is
// said in a notice, never dropped silently.
//
// Talking: getUserMedia (echo cancellation and noise suppression on) → an AudioWorklet that
// converts to 16 kHz mono S16LE in 20 ms chunks → the socket. The server holds the talk lock
// and cuts a talk that goes quiet, so letting go, closing the tab or losing the network ends it.
import { notify } from "./api.js";
import { socketURL, toLogin } from "./config.js";

const JITTER_S = 0.08; // start (and restart after an underrun) this far ahead: 60-120 ms target
const MAX_AHEAD_S = 0.4; // more queued than this means the clock drifted: drop and restart
const TALK_KEY = "t";
const UNAUTHENTICATED = 4401;
const ACCESS_CHANGED = 4403; // the server closed it: this person may no longer listen or talk
const TALK_FORMAT = { format: "S16LE", rate: 16000, channels: 1 };

export function initAudio(root, config) {
  if (!root) return;
  const $ = (sel) => root.querySelector(sel);
  const listenBtn = $("#audio-listen"), talkBtn = $("#audio-talk"), meter = $("#audio-level");
  const talkState = $("#audio-talker"), problem = $("#audio-problem"), statusEl = $("#audio-status");
  let ws = null, allowed = false, listening = false, talking = false, holding = false;
  let ctx = null, analyser = null, playAt = 0, format = null;
  let capture = null;

  function explain(text) {
    problem.textContent = text;
    problem.hidden = !text;
  }
  function setStatus(text) { statusEl.textContent = text; }
  function send(obj) { if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(obj)); }
  function refresh() {
    const open = ws && ws.readyState === WebSocket.OPEN;
    listenBtn.disabled = !allowed || !open;
    talkBtn.disabled = !allowed || !open;
    listenBtn.textContent = listening ? "Stop listening" : "Listen";
    listenBtn.setAttribute("aria-pressed", String(listening));
    talkBtn.classList.toggle("on-air", talking);
    talkBtn.setAttribute("aria-pressed", String(talking));
  }

  // --- the socket ------------------------------------------------------------------------
  function connect() {
    ws = new WebSocket(socketURL(config.audio_socket));
    ws.binaryType = "arraybuffer";
    ws.onopen = () => { setStatus("Connected"); refresh(); };
    ws.onmessage = (ev) => {
      if (typeof ev.data === "string") onFrame(JSON.parse(ev.data));
      else if (listening) play(ev.data);
    };
    ws.onclose = (ev) => {
      if (ev.code === UNAUTHENTICATED) { toLogin(); return; }
      listening = talking = false;
      stopCapture();
      setStatus(ev.code === ACCESS_CHANGED ? "Your access has changed: listening and talking have ended."
                                           : "Audio connection lost: reconnecting…");
      refresh();
      setTimeout(connect, 2000);
    };
  }

  function onFrame(f) {
    if (f.type === "hello") {
      allowed = f.can_listen && f.can_talk;
      showTalker(f.talker, f.you);
      if (!allowed) explain("Your role can see who is talking but may not listen or talk (operators and admins can).");
    } else if (f.type === "format") {
      format = f;
      if (f.coding_format !== "wave" || f.sample_format !== "S16LE") {
        notify(`The robot's microphone arrives as ${f.coding_format} ${f.sample_format}, which this page cannot play.`,
          "error", { key: "audio:format" });
        format = null;
      }
    } else if (f.type === "listening") {
      listening = f.on;
      if (!f.on) meter.value = 0;
    } else if (f.type === "talking") {
      talking = f.on;
      if (!f.on) {
        stopCapture();
        if (f.reason === "quiet") notify("Talk ended: no audio arrived from this microphone.", "warn");
        else if (f.reason === "estop") notify("Talk ended by the E-STOP.", "warn");
      }
    } else if (f.type === "talker") {
      showTalker(f.holder, f.you);
    } else if (f.type === "error") {
      if (f.code !== "not_talking") notify(f.message, "error", { key: `audio:${f.code}` });
      if (["busy", "estop", "forbidden", "invalid", "offline"].includes(f.code) && !talking) stopCapture();
    }
    refresh();
  }

  function showTalker(holder, you) {
    talkState.dataset.holder = holder || "";
    talkState.dataset.you = String(Boolean(you));
    talkState.textContent = holder ? (you ? "You are talking" : `${holder} is talking`) : "Nobody is talking";
  }

  // --- listening -------------------------------------------------------------------------
  function audioContext() {
    if (!ctx) {
      ctx = new AudioContext({ latencyHint: "interactive" });
      analyser = ctx.createAnalyser();
      analyser.fftSize = 2048;
      analyser.connect(ctx.destination);
      requestAnimationFrame(drawLevel);
    }
    if (ctx.state === "suspended") ctx.resume();
    return ctx;
  }

  function schedule(buffer) {
    const now = ctx.currentTime;
    if (playAt < now + 0.005 || playAt > now + MAX_AHEAD_S) playAt = now + JITTER_S;
    const source = ctx.createBufferSource();
    source.buffer = buffer;
    source.connect(analyser);
    source.start(playAt);
    playAt += buffer.duration;
  }

  function play(data) {
    if (!ctx || !format) return;
    const channels = format.channels || 1;
    const pcm = new Int16Array(data, 0, Math.floor(data.byteLength / 2));
    const frames = Math.floor(pcm.length / channels);
    if (!frames) return;
    const buffer = ctx.createBuffer(channels, frames, format.sample_rate || 16000);
    for (let c = 0; c < channels; c++) {
      const out = buffer.getChannelData(c);
      for (let i = 0; i < frames; i++) out[i] = pcm[i * channels + c] / 32768;
    }
    schedule(buffer);
  }

  function drawLevel() {
    if (analyser) {
      const samples = new Float32Array(analyser.fftSize);
      analyser.getFloatTimeDomainData(samples);
      let sum = 0;
      for (const s of samples) sum += s * s;
      meter.value = Math.min(1, Math.sqrt(sum / samples.length) * 3);
      const bins = new Float32Array(analyser.frequencyBinCount);
      analyser.getFloatFrequencyData(bins);
      let best = 0;
      for (let i = 1; i < bins.length; i++) if (bins[i] > bins[best]) best = i;
      meter.dataset.hz = sum > 0 ? String(Math.round(best * ctx.sampleRate / analyser.fftSize)) : "0";
    }
    requestAnimationFrame(drawLevel);
  }

  listenBtn.addEventListener("click", () => {
    if (!listening) audioContext();
    playAt = 0;
    send({ type: "listen", on: !listening });
  });

  // --- talking ---------------------------------------------------------------------------
  function microphoneProblem() {
    if (!window.isSecureContext) {
      return `Browsers give pages the microphone only over HTTPS or on localhost; this page is plain HTTP `
        + `at ${location.host}. Open it over HTTPS to talk.`;
    }
    if (!navigator.mediaDevices || !navigator.mediaDevices.getUserMedia || !window.AudioWorkletNode) {
      return "This browser cannot capture audio (no getUserMedia or AudioWorklet): use a current Chrome, Firefox or Safari.";
    }
    return "";
  }

  function mediaError(err) {
    if (err && (err.name === "NotAllowedError" || err.name === "SecurityError")) {
      return "Microphone permission denied: allow the microphone for this site in the browser's settings, then hold Talk again.";
    }
    if (err && (err.name === "NotFoundError" || err.name === "OverconstrainedError")) {
      return "No microphone found: plug one in (or enable it in the system settings) and hold Talk again.";
    }
    return `The microphone could not be opened: ${(err && err.message) || err}`;
  }

  async function startTalk() {
    if (holding || talkBtn.disabled) return;
    holding = true;
    const why = microphoneProblem();
    if (why) { explain(why); holding = false; return; }
    let stream;
    try {
      stream = await navigator.mediaDevices.getUserMedia({
        audio: { echoCancellation: true, noiseSuppression: true, autoGainControl: true, channelCount: 1 },
      });
    } catch (err) {
      explain(mediaError(err));
      holding = false;
      return;
    }
    if (!holding) { stream.getTracks().forEach((t) => t.stop()); return; } // let go while asking
    explain("");
    const context = audioContext();
    try {
      if (!context.audioWorklet.loaded) {
        await context.audioWorklet.addModule(config.audio_worklet);
        context.audioWorklet.loaded = true;
      }
    } catch (err) {
      stream.getTracks().forEach((t) => t.stop());
      explain(`Audio capture could not start: ${err.message || err}`);
      holding = false;
      return;
    }
    const source = context.createMediaStreamSource(stream);
    const node = new AudioWorkletNode(context, "pcm16k-capture", { numberOfInputs: 1, numberOfOutputs: 0 });
    node.port.onmessage = (ev) => { if (talking && ws.readyState === WebSocket.OPEN) ws.send(ev.data); };
    source.connect(node);
    capture = { stream, source, node };
    send({ type: "talk", on: true, ...TALK_FORMAT });
    if (!holding) stopTalk();
  }

  function stopCapture() {
    if (!capture) return;
    capture.source.disconnect();
    capture.node.port.onmessage = null;
    capture.node.disconnect();
    capture.stream.getTracks().forEach((t) => t.stop());
    capture = null;
  }

  function stopTalk() {
    if (!holding) return;
    holding = false;
    stopCapture();
    send({ type: "talk", on: false });
  }

  talkBtn.addEventListener("pointerdown", (ev) => { ev.preventDefault(); startTalk(); });
  for (const name of ["pointerup", "pointercancel", "pointerleave"]) talkBtn.addEventListener(name, stopTalk);
  document.addEventListener("keydown", (ev) => {
    if (ev.key.toLowerCase() !== TALK_KEY || ev.repeat || ev.ctrlKey || ev.metaKey || ev.altKey) return;
    if (ev.target.closest && ev.target.closest("input, textarea, select, [contenteditable]")) return;
    startTalk();
  });
  document.addEventListener("keyup", (ev) => { if (ev.key.toLowerCase() === TALK_KEY) stopTalk(); });
  window.addEventListener("blur", stopTalk);
  document.addEventListener("visibilitychange", () => { if (document.hidden) stopTalk(); });

  const why = microphoneProblem();
  if (why) explain(why);
  connect();
  refresh();
}
