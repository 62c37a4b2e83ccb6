(define (stream slide)
  (:stream sample-push
    :inputs (?t)
    :domain (Target ?t)
    :outputs (?v)
    :certified (GoodPush ?t ?v)))
