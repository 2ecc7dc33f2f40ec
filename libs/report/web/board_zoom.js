// Pan and zoom of the board faces in the cutting report's HTML page (docs/report.md), embedded
// into report.html at build time: plain script, no network, no library.
//
// Each board's faces are one image at full resolution inside <div class="zoom">; its limiting
// knots are rings in an SVG layer over it, each with its description as a tooltip. Mouse wheel
// or the + / − buttons zoom (about the pointer, or the centre), dragging pans (mouse, pen or one
// finger; two fingers pinch), double-click zooms in, "fit" shows the whole board and "⤢" opens it
// over the whole window (Esc closes). The address's hash selects a view:
//   #board=3&zoom=6&knot=68   board 3 over the whole window, 6 × the fitted scale, knot 68 centred
//   (knot optional; full=0 keeps the board in the page). The viewer writes where the image lies
// as data-view="left,top,scale,width,height" (viewport pixels of image pixel (0, 0), screen
// pixels per image pixel, and the size of the viewport it was laid out in) for tests and tools.
(function () {
  'use strict';
  var MAX_ZOOM = 64;
  var viewers = [];
  var byBoard = {};

  function clamp(v, lo, hi) {
    return Math.max(lo, Math.min(hi, v));
  }

  function Viewer(el) {
    var self = this;
    this.el = el;
    this.view = el.querySelector('.zoom-view');
    this.layer = el.querySelector('.zoom-layer');
    this.level = el.querySelector('.zoom-level');
    this.w = +el.getAttribute('data-w');
    this.h = +el.getAttribute('data-h');
    this.board = el.getAttribute('data-board');
    this.zoom = 1;
    this.cx = this.w / 2;
    this.cy = this.h / 2;
    this.full = false;

    this.view.addEventListener('wheel', function (e) {
      e.preventDefault();
      var r = self.view.getBoundingClientRect();
      var step = e.deltaMode === 1 ? 0.05 : e.deltaMode === 2 ? 1.0 : 0.0015;
      self.zoomAt(self.zoom * Math.exp(-e.deltaY * step), e.clientX - r.left, e.clientY - r.top);
    }, {passive: false});

    var pointers = {};
    var pinch = null;
    this.view.addEventListener('pointerdown', function (e) {
      pointers[e.pointerId] = {x: e.clientX, y: e.clientY};
      self.view.setPointerCapture(e.pointerId);
      self.view.classList.add('dragging');
      var ids = Object.keys(pointers);
      if (ids.length === 2) {
        var a = pointers[ids[0]], b = pointers[ids[1]];
        pinch = {d: Math.hypot(a.x - b.x, a.y - b.y) || 1, zoom: self.zoom};
      }
    });
    this.view.addEventListener('pointermove', function (e) {
      var p = pointers[e.pointerId];
      if (!p) return;
      var ids = Object.keys(pointers);
      if (ids.length === 1) {
        var s = self.scale();
        self.cx -= (e.clientX - p.x) / s;
        self.cy -= (e.clientY - p.y) / s;
        p.x = e.clientX;
        p.y = e.clientY;
        self.apply();
      } else if (ids.length === 2 && pinch) {
        p.x = e.clientX;
        p.y = e.clientY;
        var a = pointers[ids[0]], b = pointers[ids[1]];
        var r = self.view.getBoundingClientRect();
        self.zoomAt(pinch.zoom * Math.hypot(a.x - b.x, a.y - b.y) / pinch.d,
                    (a.x + b.x) / 2 - r.left, (a.y + b.y) / 2 - r.top);
      }
    });
    var up = function (e) {
      delete pointers[e.pointerId];
      pinch = null;
      if (!Object.keys(pointers).length) self.view.classList.remove('dragging');
    };
    this.view.addEventListener('pointerup', up);
    this.view.addEventListener('pointercancel', up);
    this.view.addEventListener('dblclick', function (e) {
      var r = self.view.getBoundingClientRect();
      self.zoomAt(self.zoom * 2, e.clientX - r.left, e.clientY - r.top);
    });

    Array.prototype.forEach.call(el.querySelectorAll('button[data-zoom]'), function (b) {
      b.addEventListener('click', function () {
        var what = b.getAttribute('data-zoom');
        var r = self.view.getBoundingClientRect();
        if (what === 'in') self.zoomAt(self.zoom * 2, r.width / 2, r.height / 2);
        else if (what === 'out') self.zoomAt(self.zoom / 2, r.width / 2, r.height / 2);
        else if (what === 'fit') self.show(1, self.w / 2, self.h / 2);
        else if (what === 'full') {
          if (self.full) closeFull();
          else location.hash = 'board=' + self.board + '&zoom=' + self.zoom.toFixed(2);
        }
      });
    });
  }

  // Screen pixels per image pixel at zoom 1: the whole image fits the view.
  Viewer.prototype.fitScale = function () {
    var r = this.view.getBoundingClientRect();
    return Math.min(r.width / this.w, r.height / this.h) || 1;
  };
  Viewer.prototype.scale = function () {
    return this.fitScale() * this.zoom;
  };
  // Zoom to `zoom` keeping the image point under view pixel (px, py) where it is.
  Viewer.prototype.zoomAt = function (zoom, px, py) {
    var r = this.view.getBoundingClientRect();
    var s0 = this.scale();
    var u = this.cx + (px - r.width / 2) / s0, v = this.cy + (py - r.height / 2) / s0;
    this.zoom = clamp(zoom, 1, MAX_ZOOM);
    var s1 = this.scale();
    this.cx = u - (px - r.width / 2) / s1;
    this.cy = v - (py - r.height / 2) / s1;
    this.apply();
  };
  Viewer.prototype.show = function (zoom, cx, cy) {
    this.zoom = clamp(zoom, 1, MAX_ZOOM);
    this.cx = cx;
    this.cy = cy;
    this.apply();
  };
  Viewer.prototype.layout = function () {
    // In the page: as tall as the fitted image, at least 220 px; over the window: all of it
    // below the buttons.
    var bar = this.el.querySelector('.zoom-bar');
    if (this.full) {
      this.view.style.height = Math.max(100, window.innerHeight - (bar ? bar.offsetHeight : 0)) + 'px';
    } else {
      var w = this.view.clientWidth || this.el.clientWidth;
      this.view.style.height = Math.max(220, Math.round(w * this.h / this.w)) + 'px';
    }
  };
  Viewer.prototype.apply = function () {
    var r = this.view.getBoundingClientRect();
    var s = this.scale();
    // Keep the image over the view where it is larger, centred where it is smaller.
    var hw = r.width / (2 * s), hh = r.height / (2 * s);
    this.cx = this.w <= 2 * hw ? this.w / 2 : clamp(this.cx, hw, this.w - hw);
    this.cy = this.h <= 2 * hh ? this.h / 2 : clamp(this.cy, hh, this.h - hh);
    var ox = r.width / 2 - s * this.cx, oy = r.height / 2 - s * this.cy;
    this.layer.style.transform = 'translate(' + ox + 'px,' + oy + 'px) scale(' + s + ')';
    this.layer.style.setProperty('--s', s);
    this.el.setAttribute('data-view',
                         [r.left + ox, r.top + oy, s, window.innerWidth, window.innerHeight].join(','));
    if (this.level) this.level.textContent = '× ' + this.zoom.toFixed(1);
  };
  Viewer.prototype.setFull = function (on) {
    if (this.full === on) return;
    this.full = on;
    this.el.classList.toggle('full', on);
    document.body.classList.toggle('zoom-open', viewers.some(function (v) { return v.full; }));
    this.layout();
    this.apply();
  };

  function parseHash() {
    var out = {};
    location.hash.replace(/^#/, '').split('&').forEach(function (kv) {
      var p = kv.split('=');
      if (p[0]) out[decodeURIComponent(p[0])] = decodeURIComponent(p[1] || '');
    });
    return out;
  }

  function closeFull() {
    if (location.hash) history.pushState('', document.title, location.pathname + location.search);
    onHash();
  }

  function onHash() {
    var o = parseHash();
    var v = o.board ? byBoard[o.board] : null;
    viewers.forEach(function (w) {
      if (w !== v) w.setFull(false);
    });
    if (!v) return;
    v.setFull(o.full !== '0');
    var k = o.knot ? v.el.querySelector('.knot[data-knot="' + o.knot + '"]') : null;
    var cx = k ? +k.getAttribute('data-x') : v.w / 2, cy = k ? +k.getAttribute('data-y') : v.h / 2;
    v.show(parseFloat(o.zoom) || 1, cx, cy);
    if (!v.full) v.el.scrollIntoView({block: 'center'});
  }

  function init() {
    Array.prototype.forEach.call(document.querySelectorAll('.zoom'), function (el) {
      var v = new Viewer(el);
      viewers.push(v);
      byBoard[v.board] = v;
      v.layout();
      v.apply();
    });
    window.addEventListener('resize', function () {
      viewers.forEach(function (v) {
        v.layout();
        v.apply();
      });
    });
    window.addEventListener('hashchange', onHash);
    // Again once the page's images are in: they move the board down the page.
    window.addEventListener('load', onHash);
    document.addEventListener('keydown', function (e) {
      if (e.key === 'Escape' && viewers.some(function (v) { return v.full; })) closeFull();
    });
    onHash();
  }

  if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', init);
  else init();
})();
