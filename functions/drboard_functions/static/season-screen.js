/* A season's big screen: after a while it shows the next page of racers (and after the last,
   the first again), each time fresh from the board. */
(function () {
  "use strict";
  var page = document.querySelector("[data-next]");
  if (!page) {
    return;
  }
  var hold = Number(page.getAttribute("data-hold")) || 15;
  window.setTimeout(function () {
    window.location.replace(page.getAttribute("data-next"));
  }, hold * 1000);
}());
