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
 * 3. Figures open their full-size file: each content image (notebook outputs, MyST figures) is
 *    wrapped in a link to its own file, reachable with the keyboard; icons and logos are not.
 * 4. A display equation wider than its column gets its number on the line below (hw4-book.css),
 *    measured again when the window changes width; what is still wider scrolls in its own box.
 * 5. Line breaks: an inline formula stays on one line with the bracket before it, the unit and
 *    punctuation after it, and the value glued after a formula ending in "=" ("l = 0.2 m,"); a
 *    short inline literal (an option such as --video) is never broken.
 * 6. Video players are one control bar taller than their frame (the frame at the top, see
 *    hw4-book.css), so the paused player's controls do not cover the plot.
 * 7. The header's download menu offers the whole book's PDF (the link at the foot of the chapter
 *    list, book/_ext/templates/hw4-pdf-link.html) above the theme's "print this page".
 * 8. On a touch screen the interactive 3D view sits under a veil, so that a swipe over it scrolls
 *    the page instead of turning the map; a tap lifts the veil, a touch elsewhere lowers it.
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

  function linkImages() {
    var images = document.querySelectorAll(
      ".bd-article figure img, .bd-article .cell_output img");
    Array.prototype.forEach.call(images, function (img) {
      var src = img.getAttribute("src");
      // already a link, or inline data a browser will not open as a page
      if (!src || /^data:/.test(src) || img.closest("a")) {
        return;
      }
      var link = document.createElement("a");
      link.className = "hw4-image-link";
      link.href = src;
      link.title = "Open the full-size image";
      link.setAttribute("aria-label", "Open " + figureName(img) + " at full size");
      img.parentNode.insertBefore(link, img);
      link.appendChild(img);
    });
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
      }
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

  function veilInteractive() {
    if (!window.matchMedia("(pointer: coarse)").matches) {
      return;
    }
    var views = document.querySelectorAll(".hw4-interactive");
    Array.prototype.forEach.call(views, function (view) {
      var frame = view.querySelector("iframe");
      if (!frame) {
        return;
      }
      var veil = document.createElement("button");
      veil.type = "button";
      veil.className = "hw4-veil";
      veil.setAttribute("aria-label", "Use the 3D view (a swipe over it then turns the map)");
      veil.innerHTML = "<span>Tap to rotate and zoom</span>";
      function place() {
        veil.style.height = frame.offsetHeight + "px";
      }
      veil.addEventListener("click", function () {
        veil.hidden = true;
      });
      document.addEventListener("touchstart", function (event) {
        if (veil.hidden && !frame.contains(event.target) && event.target !== frame) {
          veil.hidden = false;
        }
      }, {passive: true});
      window.addEventListener("resize", place);
      view.insertBefore(veil, frame.nextSibling);
      place();
    });
  }

  function setup() {
    forward(".primary-toggle", "pst-primary-sidebar-modal");
    forward(".secondary-toggle", "pst-secondary-sidebar-modal");
    DRAWERS.forEach(closeOnLink);
    linkImages();
    keepTogether();
    sizeVideos();
    bookPdfButton();
    veilInteractive();
    watchMaths();
  }
  if (document.readyState !== "loading") {
    setup();
  } else {
    document.addEventListener("DOMContentLoaded", setup);
  }
})();
