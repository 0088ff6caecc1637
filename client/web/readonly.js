// A viewer's page (opened from a view-only link): the panels show the session, nothing edits it.
// The controls that would change it are disabled (inputs) or hidden (buttons), and those the
// panels re-render get the same again; the view's object handles are hidden by the stylesheet
// (body.read-only).

// What a viewer's page keeps usable in the panels: help, screenshot, copying the camera, paging
// and selecting in lists, and the page's own choices (target, camera mode, material shown).
const VIEW_OK = '#help-button, #screenshot, #copy-camera-json, #copy-camera-curl, #lights-prev, ' +
    '#lights-next, #objects-refresh, #light-list button, #object-list button.name, #target, ' +
    '#camera-mode, #material';

export class ReadOnlyMode {
  constructor(panels, note) {
    this.panels = panels;
    this.note = note;            // shown while read-only
    this.on = false;
    this.changed = new Set();    // the controls it disabled or hid
    // Panels that re-render (lists, editors) or re-enable a control get read-only again.
    new MutationObserver(() => { if (this.on) this.apply(); }).observe(panels, {
      childList: true, subtree: true, attributes: true, attributeFilter: ['disabled', 'hidden']});
  }

  apply() {
    document.body.classList.toggle('read-only', this.on);
    this.note.hidden = !this.on;
    if (!this.on) return;
    for (const el of this.panels.querySelectorAll('input, select, textarea, button')) {
      if (el.matches(VIEW_OK)) continue;
      // Only what changes is written, so the observer does not wake itself.
      if (el.tagName === 'BUTTON') {
        if (!el.hidden) { el.hidden = true; this.changed.add(el); }
      } else if (!el.disabled) {
        el.disabled = true;
        this.changed.add(el);
      }
    }
  }

  set(value) {
    if (value === this.on) return;
    this.on = value;
    if (!value) {
      for (const el of this.changed) {
        if (el.tagName === 'BUTTON') el.hidden = false;
        else el.disabled = false;
      }
      this.changed.clear();
    }
    this.apply();
  }
}
