(define (stream synthetic-goodregion)
  (:stream sample-good-control
    :inputs (?t)
    :domain (Task ?t)
    :outputs (?c)
    :certified (and (Control ?t ?c) (GoodControl ?t ?c)))
  (:stream test-clear
    :inputs (?t ?c)
    :domain (Control ?t ?c)
    :certified (Clear ?t ?c)))
