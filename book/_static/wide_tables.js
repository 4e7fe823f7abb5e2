/* trackcore-book: tables that fit the text column, and a visible cue on those that cannot.
 *
 * For every table in the article, after the page (and MathJax) has laid out, and again on
 * resize and before printing:
 *   1. long tokens without spaces (file paths, test names; in code literals from 12
 *      characters on) get break opportunities (<wbr>) after "/", "_", ".", ":" and "=", so
 *      one identifier cannot widen a column;
 *   2. a table still wider than its box is set tighter ("tc-tight": smaller type, less
 *      padding, badges may wrap);
 *   3. if it is still too wide, the headers of its short-valued columns (counts, numbers)
 *      (headers longer than every value below them) are set vertically ("tc-vert"), so a
 *      header word no longer sets the column's width;
 *   4. on paper (the PDF of the book), a table still too wide is set in smaller type
 *      ("tc-small", which only book.css's print rules size);
 *   5. a table that is still too wide (a phone, a narrow window) scrolls inside its box, and
 *      the box is marked "tc-wide": book.css draws a "scroll sideways" line above the table,
 *      a shadow at the edge that hides columns, and a scrollbar that stays visible.
 * .ci/browser_check.py measures the result on every page: at 1400 px no table may be wider
 * than the text column unless its box shows the cue.
 */
(function () {
  "use strict";

  var LONG_TOKEN = /\S{28,}/;
  var LONG_CODE = /\S{12,}/;
  var SHORT_CELL = 10; // characters: a column whose body cells are all this short is "narrow"

  function article() {
    return document.querySelector("article.bd-article") || document.querySelector("main");
  }

  function breakLongTokens(table) {
    if (table.dataset.tcTokens) return;
    table.dataset.tcTokens = "1";
    var walker = document.createTreeWalker(table, NodeFilter.SHOW_TEXT, {
      acceptNode: function (n) {
        if (n.parentElement && n.parentElement.closest("mjx-container, script, style")) {
          return NodeFilter.FILTER_REJECT;
        }
        var long = n.parentElement && n.parentElement.closest("code") ? LONG_CODE : LONG_TOKEN;
        return long.test(n.nodeValue) ? NodeFilter.FILTER_ACCEPT : NodeFilter.FILTER_SKIP;
      },
    });
    var nodes = [];
    while (walker.nextNode()) nodes.push(walker.currentNode);
    nodes.forEach(function (node) {
      var long = node.parentElement.closest("code") ? LONG_CODE : LONG_TOKEN;
      var frag = document.createDocumentFragment();
      node.nodeValue.split(/(\s+)/).forEach(function (word) {
        if (!long.test(word)) {
          frag.appendChild(document.createTextNode(word));
          return;
        }
        word.split(/(?<=[\/_.:=])/).forEach(function (piece, i) {
          if (i > 0) frag.appendChild(document.createElement("wbr"));
          frag.appendChild(document.createTextNode(piece));
        });
      });
      node.parentNode.replaceChild(frag, node);
    });
  }

  function scrollBox(table) {
    var art = article();
    for (var a = table.parentElement; a && a !== art; a = a.parentElement) {
      var ox = getComputedStyle(a).overflowX;
      if (ox === "auto" || ox === "scroll") return a;
    }
    // no scrolling box: give the table one, as the theme does for Markdown tables
    var box = document.createElement("div");
    box.className = "pst-scrollable-table-container";
    table.parentNode.insertBefore(box, table);
    box.appendChild(table);
    return box;
  }

  function visibleWidth(table, box) {
    var art = article();
    var cs = getComputedStyle(art);
    var w = art.clientWidth - parseFloat(cs.paddingLeft) - parseFloat(cs.paddingRight);
    for (var a = table.parentElement; a && a !== art; a = a.parentElement) {
      if (getComputedStyle(a).overflowX !== "visible") w = Math.min(w, a.clientWidth);
    }
    return w;
  }

  function tooWide(table, box) {
    return Math.max(table.scrollWidth, table.getBoundingClientRect().width) >
      visibleWidth(table, box) + 1;
  }

  function markNarrowColumns(table) {
    var head = table.tHead && table.tHead.rows[table.tHead.rows.length - 1];
    if (!head || head.cells.length < 6) return false;
    var bodyRows = [];
    for (var b = 0; b < table.tBodies.length; b++) {
      for (var r = 0; r < table.tBodies[b].rows.length; r++) {
        bodyRows.push(table.tBodies[b].rows[r]);
      }
    }
    if (!bodyRows.length) return false;
    var any = false;
    for (var c = 0; c < head.cells.length; c++) {
      var th = head.cells[c];
      if (th.colSpan !== 1) continue;
      var longest = 0;
      var narrow = bodyRows.every(function (row) {
        var cell = row.cells[c];
        var n = cell ? cell.textContent.trim().length : 0;
        longest = Math.max(longest, n);
        return n <= SHORT_CELL;
      });
      // vertical only where the header, not the values, sets the column's width
      if (narrow && th.textContent.trim().length > longest + 1) {
        if (!th.querySelector(":scope > .tc-vert-text")) {
          var span = document.createElement("span");
          span.className = "tc-vert-text";
          while (th.firstChild) span.appendChild(th.firstChild);
          th.appendChild(span);
        }
        th.classList.add("tc-vert");
        any = true;
      }
    }
    return any;
  }

  function reset(table, box) {
    table.classList.remove("tc-tight", "tc-small");
    table.querySelectorAll("th.tc-vert").forEach(function (th) {
      th.classList.remove("tc-vert");
    });
    box.classList.remove("tc-wide");
  }

  function fit(table) {
    if (!table.getClientRects().length) return; // folded away
    breakLongTokens(table);
    var box = scrollBox(table);
    reset(table, box);
    if (!tooWide(table, box)) return;
    table.classList.add("tc-tight");
    if (!tooWide(table, box)) return;
    if (markNarrowColumns(table) && !tooWide(table, box)) return;
    table.classList.add("tc-small"); // smaller type still, on paper only (book.css)
    if (!tooWide(table, box)) return;
    box.classList.add("tc-wide");
  }

  function fitAll() {
    var art = article();
    if (!art) return;
    art.querySelectorAll("table").forEach(fit);
  }

  var pending = null;
  function later() {
    if (pending) cancelAnimationFrame(pending);
    pending = requestAnimationFrame(function () {
      pending = null;
      fitAll();
    });
  }

  function afterMathJax() {
    var start = Date.now();
    (function poll() {
      if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
        MathJax.startup.promise.then(fitAll, fitAll);
      } else if (Date.now() - start < 15000) {
        setTimeout(poll, 100);
      }
    })();
  }

  function start() {
    fitAll();
    if (document.querySelector(".math")) afterMathJax();
    window.addEventListener("resize", later);
    window.addEventListener("beforeprint", fitAll);
    // a folded <details> or dropdown that opens shows tables that were not measured
    document.addEventListener("toggle", later, true);
  }

  if (document.readyState === "loading") {
    document.addEventListener("DOMContentLoaded", start);
  } else {
    start();
  }
})();
