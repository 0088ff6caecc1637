// The JPEG path's picture: stream parts given to an <img> as blob URLs, one load at a time, each
// described (size, sequence, render scale) from the part itself, not read back from the <img>.

import {imageSize} from './adaptive.js';

export class ImagePresenter {
  // `onShown(figures)`: a part shows, {id, width, height, sequence, interactive}.
  constructor(img, onShown) {
    this.img = img;
    this.onShown = onShown;
    this.urls = [];             // object URLs of parts given to the <img>, oldest first
    this.loading = new Map();   // object URL -> the figures of the part it holds
    // The newest part that came while the <img> was still loading the one before ({stream,
    // part, id, current}): it goes to the <img> once that one has loaded, and a newer part
    // replaces it. Given at once, it cancelled the load under way: on lavapipe 10-20% of a drag's
    // parts were made into Blobs and object URLs and loaded part way, and never shown.
    this.held = null;

    img.addEventListener('load', () => {
      // The newest part shows: the parts before it are no longer needed.
      const shown = img.src;
      const figures = this.loading.get(shown);
      this.loading.clear();
      for (const url of this.urls.filter((u) => u !== shown)) URL.revokeObjectURL(url);
      this.urls = this.urls.filter((u) => u === shown);
      if (figures) this.onShown(figures);
      this.presentHeld();
    });
    // A part the <img> cannot decode: nothing shows it; the next part may.
    img.addEventListener('error', () => {
      this.loading.clear();
      this.presentHeld();
    });
  }

  // A part of `stream` named `id`: to the <img> now, or once the part it is loading has loaded.
  // `current()` says whether its stream is still the view's when its turn comes.
  show(stream, part, id, current) {
    if (this.loading.size > 0) {
      this.held = {stream, part, id, current};
      return;
    }
    this.present(stream, part, id);
  }

  presentHeld() {
    const held = this.held;
    this.held = null;
    if (held && held.current()) this.present(held.stream, held.part, held.id);
  }

  // Gives one part to the <img>. data-shown names the stream it came from, data-frame its
  // X-Myriad-Frame number and data-interactive its X-Myriad-Interactive render scale (empty for
  // a full-quality frame), for whoever inspects the page (the browser test does). Its size is
  // the part's (X-Myriad-Width/-Height, else the image's own header, else the asked size at its
  // scale), as a video chunk's header gives it.
  present(stream, part, id) {
    const h = part.headers;
    const url = URL.createObjectURL(new Blob([part.body], {type: h['content-type']}));
    this.urls.push(url);
    this.img.src = url;
    this.img.dataset.shown = stream.key;
    this.img.dataset.frame = h['x-myriad-frame'] || '';
    this.img.dataset.interactive = h['x-myriad-interactive'] || '';
    const interactive = Number(h['x-myriad-interactive']) || 0;
    const asked = new URLSearchParams(stream.key.slice(stream.key.indexOf('?') + 1));
    const size = Number(h['x-myriad-width']) > 0 && Number(h['x-myriad-height']) > 0
        ? {width: Number(h['x-myriad-width']), height: Number(h['x-myriad-height'])}
        : imageSize(part.body) || {
          width: Math.max(1, Math.round(Number(asked.get('width')) * (interactive || 1))),
          height: Math.max(1, Math.round(Number(asked.get('height')) * (interactive || 1)))};
    this.loading.set(url, {id, ...size, sequence: Number(this.img.dataset.frame) || 0, interactive});
  }

  // Nothing of the old session stays: no picture, no pending part.
  clear() {
    this.img.removeAttribute('src');
    delete this.img.dataset.stream;
    delete this.img.dataset.shown;
    delete this.img.dataset.frame;
    delete this.img.dataset.interactive;
    for (const url of this.urls) URL.revokeObjectURL(url);
    this.urls = [];
    this.loading.clear();
    this.held = null;
  }
}
