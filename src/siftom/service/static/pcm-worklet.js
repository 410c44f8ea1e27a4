// siftom: microphone samples -> 16 kHz mono 16-bit PCM, posted in 20 ms (320-sample) chunks.
// Runs in the AudioWorklet scope; `sampleRate` is the AudioContext's rate. At 16 kHz (the page
// asks the browser for it, which resamples properly) samples are copied; at any other rate they
// are interpolated linearly.
"use strict";

class Pcm16k extends AudioWorkletProcessor {
  constructor() {
    super();
    this.step = sampleRate / 16000; // input samples per output sample
    this.t = 1; // position of the next output sample, in input samples after `prev`
    this.prev = 0;
    this.out = new Int16Array(320);
    this.n = 0;
  }

  push(v) {
    const s = Math.max(-1, Math.min(1, v));
    this.out[this.n++] = s < 0 ? s * 32768 : s * 32767;
    if (this.n === this.out.length) {
      this.port.postMessage(this.out.buffer, [this.out.buffer]);
      this.out = new Int16Array(320);
      this.n = 0;
    }
  }

  process(inputs) {
    const x = inputs[0] && inputs[0][0];
    if (!x) return true;
    if (this.step === 1) {
      for (let i = 0; i < x.length; i++) this.push(x[i]);
      return true;
    }
    for (let i = 0; i < x.length; i++) {
      const cur = x[i];
      while (this.t <= 1) {
        this.push(this.prev + (cur - this.prev) * this.t);
        this.t += this.step;
      }
      this.t -= 1;
      this.prev = cur;
    }
    return true;
  }
}

registerProcessor("pcm16k", Pcm16k);
