/* Sidebar toggles that work at every width (sphinx-book-theme 1.3.0 with pydata-sphinx-theme 0.17.1).
 *
 * Both themes wire only the first `.primary-toggle` / `.secondary-toggle` on the page
 * (document.querySelector), which since pydata-sphinx-theme 0.17 is the hidden navbar button:
 * the visible buttons in the article header do nothing, on phones and on desktops alike
 * (pydata/pydata-sphinx-theme#2451, executablebooks/sphinx-book-theme#988). Every other toggle
 * forwards its click to that first, wired one, which opens the drawer below 992 px and collapses
 * the primary sidebar above.
 */
(function () {
  "use strict";
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
  function setup() {
    forward(".primary-toggle", "pst-primary-sidebar-modal");
    forward(".secondary-toggle", "pst-secondary-sidebar-modal");
  }
  if (document.readyState !== "loading") {
    setup();
  } else {
    document.addEventListener("DOMContentLoaded", setup);
  }
})();
