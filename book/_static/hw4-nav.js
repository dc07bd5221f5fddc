/* Navigation, figures and equations on every page of the HTML book
 * (sphinx-book-theme 1.3.0 with pydata-sphinx-theme 0.17.1).
 *
 * 1. Sidebar toggles that work at every width. Both themes wire only the first `.primary-toggle` /
 *    `.secondary-toggle` on the page (document.querySelector), which since pydata-sphinx-theme 0.17
 *    is the hidden navbar button: the visible buttons in the article header do nothing, on phones
 *    and on desktops alike (pydata/pydata-sphinx-theme#2451, executablebooks/sphinx-book-theme#988).
 *    Every other toggle forwards its click to that first, wired one, which opens the drawer below
 *    992 px and collapses the primary sidebar above.
 * 2. A drawer closes when a link in it is followed: the chapter list's and the page contents'
 *    (on a phone the page would otherwise jump behind a drawer that covers most of the screen).
 * 3. Figures zoom in the page: each content image (notebook outputs, MyST figures) is wrapped in a
 *    link to its own file, reachable with the keyboard; icons and logos are not. A click or tap
 *    opens the figure in a full-screen viewer at a readable size (its text about 12 CSS px high,
 *    instead of a third of that in a phone's column), panned by dragging or swiping and zoomed with
 *    the buttons, a pinch, Ctrl + wheel or the + / - keys; Esc, the close button or the browser's
 *    Back closes it. A modified click (new tab) still opens the file. On a phone a "Zoom" button
 *    under each figure says so, covering nothing.
 * 4. A display equation wider than its column gets its number on the line below (hw4-book.css),
 *    measured again when the window changes width; what is still wider scrolls in its own box.
 * 5. Line breaks: an inline formula stays on one line with the bracket before it, the unit and
 *    punctuation after it, and the value glued after a formula ending in "=" ("l = 0.2 m,"); a
 *    short inline literal (an option such as --video) is never broken, and a long one (a command
 *    line) only at its spaces, not at the hyphens of "--scans".
 * 6. Video players are one control bar taller than their frame (the frame at the top, see
 *    hw4-book.css), so the paused player's controls do not cover the plot.
 * 7. The header's download menu offers the whole book's PDF (the link at the foot of the chapter
 *    list, book/_ext/templates/hw4-pdf-link.html) above the theme's "print this page".
 * 8. An interactive 3D view (`.hw4-interactive`, data-src and data-title) shows a still image and
 *    loads nothing more until its button is clicked: then, where a canvas offers WebGL, an iframe
 *    of data-src of the still's size replaces the still; without WebGL the still stays and one
 *    line says why. On a touch screen the view then sits under a veil, so that a swipe over it
 *    scrolls the page instead of turning the map; a tap lifts the veil, a touch elsewhere lowers it.
 * 9. A table or code cell wider than its column shows that it scrolls: a shade at each edge that
 *    has more to show (hw4-book.css), updated as it scrolls and when the window changes width.
 * 10. The chapter list opens with the book's title in view: pydata-sphinx-theme scrolls the
 *    sidebar until the current page's link sits a quarter down it whenever that link is in the
 *    lower half of the window, which on the last chapters (T5, T5 beyond, T6) scrolls the title
 *    away although the link was in view; the sidebar is scrolled back as far as the link allows.
 */
(function () {
  "use strict";
  var DRAWERS = ["pst-primary-sidebar-modal", "pst-secondary-sidebar-modal"];

  function forward(selector, dialogId) {
    var buttons = document.querySelectorAll(selector);
    var wired = buttons[0];
    var dialog = document.getElementById(dialogId);
    Array.prototype.slice.call(buttons, 1).forEach(function (button) {
      button.addEventListener("click", function (event) {
        event.preventDefault();
        event.stopPropagation();
        if (dialog && dialog.open) {
          return;
        }
        wired.click();
      });
    });
  }

  function closeOnLink(dialogId) {
    var dialog = document.getElementById(dialogId);
    if (!dialog) {
      return;
    }
    // Capture phase, before the link's default action. A link to another page: the drawer closes
    // and the browser follows the link. A link to a section of this page: the jump waits until
    // the drawer has closed, because on closing the theme gives the focus back to the button
    // that opened it, and that focus() scrolls the page (by some 500 px on a phone) after the
    // jump. Modified clicks (new tab or window) leave the drawer open.
    dialog.addEventListener("click", function (event) {
      var link = event.target.closest && event.target.closest("a[href]");
      if (!link || !dialog.open || !dialog.contains(link)) {
        return;
      }
      if (event.ctrlKey || event.metaKey || event.shiftKey || event.altKey || event.button > 0) {
        return;
      }
      var here = link.hash && link.pathname === window.location.pathname &&
        link.search === window.location.search;
      var target = here && document.getElementById(decodeURIComponent(link.hash.slice(1)));
      if (target) {
        event.preventDefault();
        dialog.addEventListener("close", function () {
          // after the theme's own close listener (registered when the drawer opened)
          if (window.location.hash === link.hash) {
            target.scrollIntoView();
          } else {
            window.location.hash = link.hash;
          }
        }, {once: true});
      }
      dialog.close();
    }, true);
  }

  function figureName(img) {
    var figure = img.closest("figure");
    var number = figure && figure.querySelector(".caption-number");
    return number ? number.textContent.trim() : "figure";
  }

  // [CSS px per image px] the viewer's first zoom on a small screen: the figures are drawn at
  // 200 dpi with text of 8-9 pt, i.e. 22-25 image px, which this shows at 12-14 CSS px
  var READABLE = 0.55;
  var MAX_ZOOM = 2;
  var zoom = null; // the viewer, made on first use

  function makeViewer() {
    var dialog = document.createElement("dialog");
    dialog.className = "hw4-zoom";
    dialog.setAttribute("aria-label", "Figure viewer");
    dialog.innerHTML =
      '<div class="hw4-zoom-bar">' +
      '<span class="hw4-zoom-title"></span>' +
      '<button type="button" data-zoom="out" aria-label="Zoom out" title="Zoom out (-)">\u2212</button>' +
      '<button type="button" data-zoom="fit" aria-label="Fit the screen" title="Fit the screen (0)">Fit</button>' +
      '<button type="button" data-zoom="in" aria-label="Zoom in" title="Zoom in (+)">+</button>' +
      '<a class="hw4-zoom-file" target="_blank" rel="noopener" title="Open the image file">File</a>' +
      '<button type="button" data-zoom="close" aria-label="Close" title="Close (Esc)">\u00d7</button>' +
      '</div><div class="hw4-zoom-pane" tabindex="-1"><img alt=""></div>';
    document.body.appendChild(dialog);
    var pane = dialog.querySelector(".hw4-zoom-pane");
    var img = pane.querySelector("img");
    var state = {dialog: dialog, pane: pane, img: img, scale: 1, fit: 1, pushed: false};

    function fitScale() {
      var w = img.naturalWidth || 1, h = img.naturalHeight || 1;
      return Math.min(1, pane.clientWidth / w, pane.clientHeight / h);
    }
    // zoom to `scale` keeping the image point under (px, py) [pane px] where it is
    function setScale(scale, px, py) {
      scale = Math.max(state.fit, Math.min(MAX_ZOOM, scale));
      if (px === undefined) {
        px = pane.clientWidth / 2;
        py = pane.clientHeight / 2;
      }
      var x = (pane.scrollLeft + px - img.offsetLeft) / state.scale;
      var y = (pane.scrollTop + py - img.offsetTop) / state.scale;
      state.scale = scale;
      img.style.width = Math.round(img.naturalWidth * scale) + "px";
      img.style.height = Math.round(img.naturalHeight * scale) + "px";
      pane.scrollLeft = x * scale + img.offsetLeft - px;
      pane.scrollTop = y * scale + img.offsetTop - py;
      dialog.dataset.scale = scale.toFixed(3);
    }
    state.setScale = setScale;
    state.start = function () {
      state.fit = fitScale();
      state.scale = state.fit;
      setScale(Math.max(state.fit, Math.min(1, READABLE)), 0, 0);
      pane.scrollLeft = 0;
      pane.scrollTop = 0;
    };

    dialog.addEventListener("click", function (event) {
      var button = event.target.closest("button[data-zoom]");
      if (!button) {
        return;
      }
      var what = button.getAttribute("data-zoom");
      if (what === "close") {
        dialog.close();
      } else if (what === "fit") {
        setScale(state.fit);
      } else {
        setScale(state.scale * (what === "in" ? 1.5 : 1 / 1.5));
      }
    });
    dialog.addEventListener("keydown", function (event) {
      if (event.key === "+" || event.key === "=") {
        setScale(state.scale * 1.5);
      } else if (event.key === "-") {
        setScale(state.scale / 1.5);
      } else if (event.key === "0") {
        setScale(state.fit);
      } else {
        return;
      }
      event.preventDefault();
    });
    img.addEventListener("dblclick", function (event) {
      var r = pane.getBoundingClientRect();
      var near = Math.abs(state.scale - state.fit) < 1e-3;
      setScale(near ? Math.max(READABLE, state.fit * 2) : state.fit,
               event.clientX - r.left, event.clientY - r.top);
    });
    pane.addEventListener("wheel", function (event) {
      if (!event.ctrlKey) {
        return; // a plain wheel scrolls (pans) the figure
      }
      event.preventDefault();
      var r = pane.getBoundingClientRect();
      setScale(state.scale * Math.exp(-event.deltaY / 300), event.clientX - r.left,
               event.clientY - r.top);
    }, {passive: false});
    // a mouse drags the figure; touch pans natively (the pane scrolls)
    var drag = null;
    pane.addEventListener("pointerdown", function (event) {
      if (event.pointerType !== "mouse" || event.button !== 0) {
        return;
      }
      drag = {x: event.clientX, y: event.clientY, left: pane.scrollLeft, top: pane.scrollTop};
      pane.classList.add("hw4-dragging");
      event.preventDefault();
    });
    window.addEventListener("pointermove", function (event) {
      if (drag) {
        pane.scrollLeft = drag.left - (event.clientX - drag.x);
        pane.scrollTop = drag.top - (event.clientY - drag.y);
      }
    });
    window.addEventListener("pointerup", function () {
      drag = null;
      pane.classList.remove("hw4-dragging");
    });
    // two fingers pinch
    var pinch = null;
    function spread(touches) {
      var r = pane.getBoundingClientRect();
      return {d: Math.hypot(touches[0].clientX - touches[1].clientX,
                            touches[0].clientY - touches[1].clientY),
              x: (touches[0].clientX + touches[1].clientX) / 2 - r.left,
              y: (touches[0].clientY + touches[1].clientY) / 2 - r.top};
    }
    pane.addEventListener("touchstart", function (event) {
      if (event.touches.length === 2) {
        pinch = {start: spread(event.touches), scale: state.scale};
      }
    }, {passive: true});
    pane.addEventListener("touchmove", function (event) {
      if (pinch && event.touches.length === 2) {
        event.preventDefault();
        var now = spread(event.touches);
        setScale(pinch.scale * now.d / Math.max(1, pinch.start.d), now.x, now.y);
      }
    }, {passive: false});
    pane.addEventListener("touchend", function (event) {
      if (event.touches.length < 2) {
        pinch = null;
      }
    });
    // the browser's Back closes the viewer instead of leaving the page
    window.addEventListener("popstate", function () {
      if (state.leaving) {
        state.leaving = false; // the history.back() of a viewer closed by its button
        return;
      }
      if (dialog.open) {
        state.pushed = false;
        dialog.close();
      }
    });
    dialog.addEventListener("close", function () {
      document.documentElement.classList.remove("hw4-zoom-open");
      img.removeAttribute("src");
      if (state.pushed) {
        state.pushed = false;
        state.leaving = true;
        history.back();
      }
      if (state.opener) {
        state.opener.focus({preventScroll: true});
      }
    });
    window.addEventListener("resize", function () {
      if (dialog.open) {
        var fit = fitScale();
        var atFit = Math.abs(state.scale - state.fit) < 1e-3;
        state.fit = fit;
        setScale(atFit ? fit : state.scale);
      }
    });
    return state;
  }

  function openViewer(link) {
    var source = link.querySelector("img");
    if (!source) {
      return;
    }
    zoom = zoom || makeViewer();
    var z = zoom;
    z.opener = link;
    z.dialog.querySelector(".hw4-zoom-title").textContent = figureName(source);
    z.dialog.querySelector(".hw4-zoom-file").href = link.href;
    z.img.alt = source.alt;
    z.img.style.width = "";
    z.img.style.height = "";
    function shown() {
      z.start();
      z.pane.focus({preventScroll: true});
    }
    z.img.onload = shown;
    z.img.src = link.getAttribute("href");
    document.documentElement.classList.add("hw4-zoom-open");
    z.dialog.showModal();
    try {
      history.pushState({hw4Zoom: true}, "");
      z.pushed = true;
    } catch (e) {
      z.pushed = false; // some file:// pages refuse it; Esc and the close button still work
    }
    if (z.img.complete && z.img.naturalWidth) {
      shown();
    }
  }

  function zoomButton(link) {
    var button = document.createElement("button");
    button.type = "button";
    button.className = "hw4-zoom-button";
    button.setAttribute("aria-label", "Zoom into " + figureName(link.querySelector("img")));
    button.textContent = "Zoom \u2922";
    button.addEventListener("click", function () {
      openViewer(link);
    });
    return button;
  }

  function linkImages() {
    var images = document.querySelectorAll(
      ".bd-article figure img, .bd-article .cell_output img, .bd-article img.hw4-interactive-still");
    Array.prototype.forEach.call(images, function (img) {
      var src = img.getAttribute("src");
      // inline data a browser will not open as a page (the still of an interactive view zooms
      // like any figure until its button replaces it by the view)
      if (!src || /^data:/.test(src)) {
        return;
      }
      var link = img.closest("a");
      if (link) {
        // Sphinx's own link around a figure with a width (a.image-reference to the image
        // itself) becomes the viewer's link; any other link is left as it is
        if (!link.classList.contains("image-reference") || link.getAttribute("href") !== src) {
          return;
        }
        link.classList.add("hw4-image-link");
      } else {
        link = document.createElement("a");
        link.className = "hw4-image-link";
        link.href = src;
        img.parentNode.insertBefore(link, img);
        link.appendChild(img);
      }
      link.title = "Open the full-size image";
      link.setAttribute("aria-label", "Open " + figureName(img) + " at full size");
      link.addEventListener("click", function (event) {
        if (event.ctrlKey || event.metaKey || event.shiftKey || event.altKey || event.button > 0) {
          return; // a new tab or window: the file itself
        }
        event.preventDefault();
        openViewer(link);
      });
      link.parentNode.insertBefore(zoomButton(link), link.nextSibling);
    });
  }

  // A table or code cell wider than its column: classes that say which edges have more to
  // show, for the shades of hw4-book.css, which fade into the box's own background.
  function scrollCues() {
    var boxes = document.querySelectorAll(
      ".bd-article .pst-scrollable-table-container, .bd-article div.highlight > pre");
    var all = [];
    Array.prototype.forEach.call(boxes, function (box) {
      var wrap = document.createElement("div");
      wrap.className = "hw4-scroll-cue";
      box.parentNode.insertBefore(wrap, box);
      wrap.appendChild(box);
      var caption = box.querySelector("caption");
      function update() {
        // the shades start below the caption, which stays in view (sticky) and is not covered
        wrap.style.setProperty("--hw4-cue-top", (caption ? caption.offsetHeight : 0) + "px");
        var bg = getComputedStyle(box).backgroundColor;
        if (bg && !/^(transparent|rgba\(0, 0, 0, 0\))$/.test(bg)) {
          wrap.style.setProperty("--hw4-cue-bg", bg);
        }
        var more = box.scrollWidth - box.clientWidth;
        wrap.classList.toggle("hw4-more-left", more > 1 && box.scrollLeft > 1);
        wrap.classList.toggle("hw4-more-right", more > 1 && box.scrollLeft < more - 1);
      }
      box.addEventListener("scroll", update, {passive: true});
      if (window.ResizeObserver) {
        // also when a folded cell is unfolded (the box then gets its width for the first time)
        new ResizeObserver(update).observe(box);
      }
      all.push(update);
      update();
    });
    var timer = null;
    window.addEventListener("resize", function () {
      clearTimeout(timer);
      timer = setTimeout(function () {
        all.forEach(function (update) {
          update();
        });
      }, 100);
    });
    if (document.fonts && document.fonts.ready) {
      document.fonts.ready.then(function () {
        all.forEach(function (update) {
          update();
        });
      });
    }
  }

  function markWideMaths() {
    var maths = document.querySelectorAll("div.math");
    // Measure every equation with its number beside it first, then set the classes: no
    // layout is forced between one equation's change and the next one's measurement.
    Array.prototype.forEach.call(maths, function (div) {
      div.classList.remove("hw4-math-wide");
    });
    var wide = Array.prototype.filter.call(maths, function (div) {
      var box = div.querySelector("mjx-container");
      return box && div.querySelector("span.eqno") && box.scrollWidth > box.clientWidth + 1;
    });
    wide.forEach(function (div) {
      div.classList.add("hw4-math-wide");
    });
  }

  function watchMaths() {
    var mj = window.MathJax;
    var ready = mj && mj.startup && mj.startup.promise ? mj.startup.promise : Promise.resolve();
    var fonts = document.fonts && document.fonts.ready ? document.fonts.ready : Promise.resolve();
    Promise.all([ready, fonts]).then(markWideMaths, function () {});
    var width = window.innerWidth;
    var timer = null;
    window.addEventListener("resize", function () {
      if (window.innerWidth === width) {
        return; // a phone's address bar changing the height is no reason to measure again
      }
      width = window.innerWidth;
      clearTimeout(timer);
      timer = setTimeout(markWideMaths, 150);
    });
  }

  // Split the text node `node` at `n` characters from its start (or its end when n < 0) and
  // return the part split off (a new text node before or after `node`).
  function splitText(node, n) {
    if (n >= 0) {
      var head = document.createTextNode(node.nodeValue.slice(0, n));
      node.nodeValue = node.nodeValue.slice(n);
      node.parentNode.insertBefore(head, node);
      return head;
    }
    var tail = document.createTextNode(node.nodeValue.slice(node.nodeValue.length + n));
    node.nodeValue = node.nodeValue.slice(0, node.nodeValue.length + n);
    node.parentNode.insertBefore(tail, node.nextSibling);
    return tail;
  }

  function endsWithEquals(math) {
    var mml = math.querySelector("mjx-assistive-mml math, math");
    var text = mml ? mml.textContent : math.textContent.replace(/\\\)\s*$/, "");
    return /=\s*$/.test(text);
  }

  function keepTogether() {
    var maths = document.querySelectorAll(".bd-article span.math");
    Array.prototype.forEach.call(maths, function (math) {
      var parts = [math];
      var prev = math.previousSibling;
      if (prev && prev.nodeType === 3 && /[(\[]$/.test(prev.nodeValue)) {
        parts.unshift(splitText(prev, -1));       // "(" right before the formula
      }
      var next = math.nextSibling;
      if (endsWithEquals(math) && next) {          // "l =" and the value after it
        if (next.nodeType === 3 && /^\s+$/.test(next.nodeValue) && next.nextSibling &&
            next.nextSibling.nodeType === 1) {       // a glued value: " " then an element
          parts.push(next, next.nextSibling);
          next = next.nextSibling.nextSibling;
        } else if (next.nodeType === 1) {
          parts.push(next);
          next = next.nextSibling;
        } else if (next.nodeType === 3) {           // a typed value: " 0.2"
          var v = /^\s*[\u2212+-]?[\d.,]+/.exec(next.nodeValue);
          if (v) {
            parts.push(splitText(next, v[0].length));
          }
        }
      }
      if (next && next.nodeType === 3) {
        var m = /^(\u00a0[^\s.,;:!?()]+)?[.,;:!?)\u2019]*/.exec(next.nodeValue);
        if (m[0]) {                                // "\u00a0m" (a unit), then punctuation
          parts.push(splitText(next, m[0].length));
        }
      }
      if (parts.length === 1) {
        return;
      }
      var wrap = document.createElement("span");
      wrap.className = "hw4-math-nowrap";
      parts[0].parentNode.insertBefore(wrap, parts[0]);
      parts.forEach(function (node) {
        wrap.appendChild(node);
      });
    });
    var labels = document.querySelectorAll(".bd-article table td:first-child");
    Array.prototype.forEach.call(labels, function (cell) {
      if (cell.textContent.trim().length <= 14) {
        cell.classList.add("hw4-nowrap");
      }
    });
    var literals = document.querySelectorAll(".bd-article code.literal");
    Array.prototype.forEach.call(literals, function (code) {
      if (code.textContent.length <= 24) {
        code.classList.add("hw4-code-short");
        return;
      }
      // a long literal (a command line) breaks at its spaces only: each short token (Sphinx's
      // span.pre, e.g. "--scans") stays whole, never split at its hyphens; a token longer than
      // a line (a file path) may still break anywhere
      Array.prototype.forEach.call(code.querySelectorAll("span.pre"), function (token) {
        if (token.textContent.length <= 24) {
          token.classList.add("hw4-code-token");
        }
      });
    });
  }

  // [CSS px] the height of a media player's controls with their shade: Chromium draws a row of
  // buttons above a progress bar, on desktops and phones alike
  var CONTROLS = 92;

  function sizeVideos() {
    var videos = document.querySelectorAll("video.hw4-video");
    Array.prototype.forEach.call(videos, function (video) {
      function fit() {
        if (!video.videoWidth || !video.clientWidth) {
          return;
        }
        video.style.height = Math.round(
          video.clientWidth * video.videoHeight / video.videoWidth + CONTROLS) + "px";
      }
      video.addEventListener("loadedmetadata", fit);
      window.addEventListener("resize", fit);
      fit();
    });
  }

  function bookPdfButton() {
    var book = document.querySelector(".hw4-pdf-link a");
    var buttons = document.querySelectorAll(".btn-download-pdf-button");
    if (!book) {
      return;
    }
    Array.prototype.forEach.call(buttons, function (button) {
      var item = button.closest("li");
      if (!item) {
        return;
      }
      var link = document.createElement("a");
      link.className = "btn btn-sm dropdown-item hw4-book-pdf-button";
      link.href = book.href;
      link.setAttribute("download", "");
      link.title = "Download the whole book as one PDF";
      link.innerHTML = button.innerHTML;
      var text = link.querySelector(".btn__text-container");
      if (text) {
        text.textContent = ".pdf (whole book)";
      }
      var own = button.querySelector(".btn__text-container");
      if (own) {
        own.textContent = "print this page";
      }
      var li = document.createElement("li");
      li.appendChild(link);
      item.parentNode.insertBefore(li, item);
    });
  }

  function veil(view, frame) {
    if (!window.matchMedia("(pointer: coarse)").matches || view.querySelector(".hw4-veil")) {
      return;
    }
    var cover = document.createElement("button");
    cover.type = "button";
    cover.className = "hw4-veil";
    cover.setAttribute("aria-label", "Use the 3D view (a swipe over it then turns the map)");
    cover.innerHTML = "<span>Tap to rotate and zoom</span>";
    function place() {
      cover.style.height = frame.offsetHeight + "px";
    }
    cover.addEventListener("click", function () {
      cover.hidden = true;
    });
    document.addEventListener("touchstart", function (event) {
      if (cover.hidden && !frame.contains(event.target) && event.target !== frame) {
        cover.hidden = false;
      }
    }, {passive: true});
    window.addEventListener("resize", place);
    view.insertBefore(cover, frame.nextSibling);
    place();
  }

  function hasWebGL() {
    try {
      var canvas = document.createElement("canvas");
      return !!(canvas.getContext("webgl2") || canvas.getContext("webgl"));
    } catch (e) {
      return false;
    }
  }

  function interactiveViews() {
    var views = document.querySelectorAll(".hw4-interactive");
    Array.prototype.forEach.call(views, function (view) {
      var frame = view.querySelector("iframe");
      if (frame) {  // a view loaded with its page
        veil(view, frame);
        return;
      }
      var button = view.querySelector(".hw4-interactive-load");
      var still = view.querySelector(".hw4-interactive-still");
      if (!button || !still || !view.dataset.src) {
        return;
      }
      button.addEventListener("click", function () {
        if (!hasWebGL()) {
          var note = view.querySelector(".hw4-interactive-note") || document.createElement("p");
          note.className = "hw4-interactive-note";
          note.setAttribute("role", "status");
          note.textContent = "The interactive 3D view needs WebGL, which this browser does not " +
            "offer: the image above is a still of it.";
          view.insertBefore(note, button.nextSibling);
          button.disabled = true;
          return;
        }
        var iframe = document.createElement("iframe");
        iframe.src = view.dataset.src;
        iframe.title = view.dataset.title || "Interactive view";
        iframe.className = "hw4-interactive-frame";
        iframe.style.width = "100%";
        iframe.style.height = Math.max(still.offsetHeight, 300) + "px";
        iframe.style.border = "0";
        // the still, with the zoom link around it and the phone's Zoom button after it
        var holder = still.closest("a.hw4-image-link") || still;
        var zoom = holder.nextElementSibling;
        view.replaceChild(iframe, holder);
        if (zoom && zoom.classList.contains("hw4-zoom-button")) {
          zoom.remove();
        }
        button.remove();
        veil(view, iframe);
        iframe.focus();
      });
    });
  }

  function setup() {
    forward(".primary-toggle", "pst-primary-sidebar-modal");
    forward(".secondary-toggle", "pst-secondary-sidebar-modal");
    DRAWERS.forEach(closeOnLink);
    linkImages();
    keepTogether();
    scrollCues();
    sizeVideos();
    bookPdfButton();
    interactiveViews();
    watchMaths();
  }
  if (document.readyState !== "loading") {
    setup();
  } else {
    document.addEventListener("DOMContentLoaded", setup);
  }

  // 10. the chapter list scrolled only as far as the current page's link needs
  function sidebarToTitle() {
    var sidebar = document.querySelector("div.bd-sidebar");
    var nav = document.querySelector(".bd-docs-nav");
    if (!sidebar || !nav || !sidebar.clientHeight) {
      return;
    }
    var active = nav.querySelectorAll("a.current, li.active > a");
    var link = active[active.length - 1];
    if (!link) {
      return;
    }
    var box = sidebar.getBoundingClientRect(), r = link.getBoundingClientRect();
    var bottom = r.bottom - box.top + sidebar.scrollTop;   // the link's foot in the sidebar's content
    var needed = Math.max(0, Math.ceil(bottom + 1.5 * r.height - sidebar.clientHeight));
    if (sidebar.scrollTop > needed) {
      sidebar.scrollTop = needed;
    }
  }
  if (document.readyState === "loading") {
    document.addEventListener("DOMContentLoaded", sidebarToTitle);   // after the theme's own
  } else {
    sidebarToTitle();
  }
  window.addEventListener("load", sidebarToTitle);
})();
