; Push pucks so that each stops at its target distance.
(define (domain slide)
  (:requirements :strips)
  (:predicates (Target ?t) (GoodPush ?t ?v) (Reached ?t))
  (:action push
    :parameters (?t ?v)
    :precondition (and (Target ?t) (GoodPush ?t ?v))
    :effect (Reached ?t)))
