/* A season's big screen: after a while it shows the next page of racers (and after the last,
   the first again), each time fresh from the board. */
(function () {
  "use strict";
  var main = document.querySelector("main[data-next]");
  if (!main) {
    return;
  }
  var hold = Number(main.getAttribute("data-hold")) || 20;
  window.setTimeout(function () {
    window.location.replace(main.getAttribute("data-next"));
  }, hold * 1000);
}());
