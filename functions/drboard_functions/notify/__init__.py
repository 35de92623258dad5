"""Announcements in the club's chat: what a change on a board says (:mod:`.events`), how it reads
on each service (:mod:`.messages`), how it is posted (:mod:`.sending`) and who posts it, once per
webhook (:mod:`.notifier`: the cloud's NotifyFunction and `drboard serve`'s background worker)."""
