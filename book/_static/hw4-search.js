/* Search snippets that work from disk (search.html only; book/_ext/hw4_html.py loads it).
 *
 * Sphinx's searchtools would fetch each result's page to cut a snippet from it, which a browser
 * refuses for a book opened from disk (file://). The text of every section is in
 * window.HW4_SEARCH_TEXT (_static/hw4-search-text.js, written at build time); under each result
 * Sphinx lists, this puts the few lines around the first search term in the result's section (or
 * page), with the terms marked, in the element Sphinx uses for its own snippets (p.context).
 */
(function () {
  "use strict";
  var TEXTS = window.HW4_SEARCH_TEXT || {};
  var LENGTH = 240; // [characters] of a snippet, as Sphinx's own

  function queryWords() {
    var q = new URLSearchParams(window.location.search).get("q") || "";
    return q.toLowerCase().split(/[^\p{L}\p{N}_-]+/u).filter(function (w) {
      return w.length > 1;
    });
  }

  // The forms of a word to look for: the word and its stem (Sphinx matched the stem).
  function forms(words) {
    var stemmer = typeof Stemmer === "function" ? new Stemmer() : null;
    var out = [];
    words.forEach(function (w) {
      out.push(w);
      var stem = stemmer ? stemmer.stemWord(w) : w;
      if (stem && stem.length > 2 && out.indexOf(stem) < 0) {
        out.push(stem);
      }
    });
    return out;
  }

  function escapeRe(s) {
    return s.replace(/[.*+?^${}()|[\]\\]/g, "\\$&");
  }

  function locate(href) {
    var url = new URL(href, window.location.href);
    var root = new URL(document.documentElement.dataset.content_root || "./",
      window.location.href);
    var path = decodeURIComponent(url.pathname);
    var base = decodeURIComponent(root.pathname);
    if (path.indexOf(base) === 0) {
      path = path.slice(base.length);
    }
    return {doc: path.replace(/\.html$/, ""), anchor: decodeURIComponent(url.hash.slice(1))};
  }

  // The snippet of `text` around the first match of `re`, as a <p class="context"> whose matches
  // are marked; null when nothing matches.
  function snippet(text, re) {
    re.lastIndex = 0;
    var m = re.exec(text);
    if (!m) {
      return null;
    }
    var start = Math.max(0, m.index - LENGTH / 3);
    if (start > 0) {
      var space = text.indexOf(" ", start);
      start = space >= 0 && space < m.index ? space + 1 : start;
    }
    var end = Math.min(text.length, start + LENGTH);
    if (end < text.length) {
      var last = text.lastIndexOf(" ", end);
      end = last > m.index ? last : end;
    }
    var part = text.slice(start, end);
    var p = document.createElement("p");
    p.className = "context hw4-snippet";
    if (start > 0) {
      p.appendChild(document.createTextNode("\u2026 "));
    }
    var at = 0;
    re.lastIndex = 0;
    var hit;
    while ((hit = re.exec(part)) !== null) {
      p.appendChild(document.createTextNode(part.slice(at, hit.index)));
      var mark = document.createElement("span");
      mark.className = "highlighted";
      mark.textContent = hit[0];
      p.appendChild(mark);
      at = hit.index + hit[0].length;
    }
    p.appendChild(document.createTextNode(part.slice(at)));
    if (end < text.length) {
      p.appendChild(document.createTextNode(" \u2026"));
    }
    return p;
  }

  function summarise(item, re) {
    if (item.querySelector("p.context")) {
      return;
    }
    var link = item.querySelector("a[href]");
    if (!link) {
      return;
    }
    var where = locate(link.getAttribute("href"));
    var sections = TEXTS[where.doc];
    if (!sections) {
      return;
    }
    var whole = Object.keys(sections).map(function (k) {
      return sections[k];
    }).join(" ");
    var p = (where.anchor && sections[where.anchor] && snippet(sections[where.anchor], re)) ||
      snippet(whole, re);
    if (!p) {
      // the term is in code only: the opening lines of the section or page
      var text = (where.anchor && sections[where.anchor]) || sections[""] || whole;
      p = snippet(text, /^\S+/g);
    }
    if (p) {
      item.appendChild(p);
    }
  }

  function setup() {
    var list = document.getElementById("search-results");
    var words = forms(queryWords());
    if (!list || !words.length) {
      return;
    }
    var re = new RegExp("\\b(?:" + words.map(escapeRe).join("|") + ")[\\p{L}\\p{N}]*", "giu");
    function all() {
      Array.prototype.forEach.call(list.querySelectorAll("li"), function (li) {
        summarise(li, re);
      });
    }
    new MutationObserver(all).observe(list, {childList: true, subtree: true});
    all();
  }

  if (document.readyState !== "loading") {
    setup();
  } else {
    document.addEventListener("DOMContentLoaded", setup);
  }
})();
