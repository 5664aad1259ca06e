window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var bad = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); });
  document.body.setAttribute('data-images', String(imgs.length));
  document.body.setAttribute('data-images-ok', bad.length === 0 ? 'yes' : 'no');
  if (bad.length) { var w = document.getElementById('img-warning'); w.style.display = 'block';
    w.textContent = bad.length + ' picture(s) failed to load.'; }
  var wide = 0;
  Array.prototype.forEach.call(document.querySelectorAll('details'), function (d) { d.open = true; });
  Array.prototype.forEach.call(document.querySelectorAll('.wrap'), function (w) {
    if (w.scrollWidth > w.clientWidth + 1) { w.classList.add('wide'); wide += 1; }
  });
  Array.prototype.forEach.call(document.querySelectorAll('details'), function (d) { d.open = false; });
  document.body.setAttribute('data-wide-tables', String(wide));
  document.body.setAttribute('data-viewport', window.innerWidth + 'x' + window.innerHeight);
  var bottom = function (id, attr) { var e = document.getElementById(id);
    if (e) { document.body.setAttribute(attr, String(Math.round(e.getBoundingClientRect().bottom + window.scrollY))); } };
  bottom('summary-table', 'data-summary-bottom');
  bottom('verdict-figure', 'data-verdict-figure-bottom');
  bottom('verdict-short', 'data-verdict-short-bottom');
});
