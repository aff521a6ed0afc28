// AudioWorklet: the microphone at the context's rate → 16 kHz mono S16LE in 20 ms chunks
// (the robot speaker's format), posted to the page as transferable ArrayBuffers.
const TARGET_RATE = 16000;
const CHUNK = 320; // samples: 20 ms at 16 kHz

class PcmCapture extends AudioWorkletProcessor {
  constructor() {
    super();
    this.step = sampleRate / TARGET_RATE; // input samples per output sample
    this.pos = 0; // where the next output sample falls, in input samples from the block start
    this.last = 0; // the previous block's last sample (interpolation across blocks)
    this.out = new Int16Array(CHUNK);
    this.filled = 0;
  }

  process(inputs) {
    const channel = inputs[0] && inputs[0][0];
    if (!channel) return true;
    // Average over each output sample's span (a cheap low-pass), then interpolate linearly.
    while (this.pos < channel.length) {
      const i = Math.floor(this.pos);
      const frac = this.pos - i;
      const a = i === 0 ? this.last : channel[i - 1];
      const b = channel[i];
      let v = a + (b - a) * frac;
      if (this.step >= 2) {
        let sum = 0, n = 0;
        for (let k = Math.max(0, i - Math.floor(this.step) + 1); k <= i; k++) { sum += channel[k]; n++; }
        v = sum / n;
      }
      v = Number.isFinite(v) ? Math.max(-1, Math.min(1, v)) : 0;
      this.out[this.filled++] = v < 0 ? v * 0x8000 : v * 0x7fff;
      if (this.filled === CHUNK) {
        this.port.postMessage(this.out.buffer, [this.out.buffer]);
        this.out = new Int16Array(CHUNK);
        this.filled = 0;
      }
      this.pos += this.step;
    }
    this.pos -= channel.length;
    this.last = channel[channel.length - 1];
    return true;
  }
}

registerProcessor("pcm16k-capture", PcmCapture);
