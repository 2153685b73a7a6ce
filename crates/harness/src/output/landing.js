// The landing page's script (embedded by landing.rs): sorts the findings table by the column
// whose heading is clicked (numbers by their value, text alphabetically; a second click
// reverses) and keeps the rows that contain the filter's text. The page reads whole without it.
(function () {
  'use strict';
  var table = document.getElementById('findings-table');
  var filter = document.getElementById('filter');
  var shown = document.getElementById('shown');
  function rows() {
    return table ? Array.prototype.slice.call(table.tBodies[0].rows) : [];
  }
  function key(row, col, type) {
    var cell = row.cells[col];
    var raw = cell.hasAttribute('data-sort') ? cell.getAttribute('data-sort') : cell.textContent;
    if (type === 'number') {
      var n = parseFloat(raw);
      return isNaN(n) ? null : n;
    }
    return raw.trim().toLowerCase();
  }
  function sortBy(th, col) {
    var type = th.getAttribute('data-type');
    var dir = th.getAttribute('aria-sort') === 'ascending' ? -1 : 1;
    var heads = table.tHead.rows[0].cells;
    for (var i = 0; i < heads.length; i++) heads[i].removeAttribute('aria-sort');
    th.setAttribute('aria-sort', dir === 1 ? 'ascending' : 'descending');
    var body = table.tBodies[0];
    var list = rows().map(function (r, i) { return { r: r, k: key(r, col, type), i: i }; });
    list.sort(function (a, b) {
      // Empty cells last, whichever the direction; ties keep their order.
      if (a.k === null || a.k === '') return b.k === null || b.k === '' ? a.i - b.i : 1;
      if (b.k === null || b.k === '') return -1;
      if (a.k < b.k) return -dir;
      if (a.k > b.k) return dir;
      return a.i - b.i;
    });
    list.forEach(function (e) { body.appendChild(e.r); });
  }
  function apply() {
    var text = filter ? filter.value.trim().toLowerCase() : '';
    var n = 0;
    rows().forEach(function (r) {
      var keep = !text || r.textContent.toLowerCase().indexOf(text) >= 0;
      r.hidden = !keep;
      if (keep) n++;
    });
    if (shown) shown.textContent = n + ' of ' + rows().length + ' findings shown';
  }
  if (table) {
    var heads = table.tHead.rows[0].cells;
    for (var c = 0; c < heads.length; c++) {
      (function (th, col) {
        th.addEventListener('click', function () { sortBy(th, col); });
      })(heads[c], c);
    }
  }
  if (filter) filter.addEventListener('input', apply);
  apply();
  window.landingReady = true;
})();
