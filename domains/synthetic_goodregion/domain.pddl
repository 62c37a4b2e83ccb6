; A synthetic task domain for learned streams: each task needs a control that is good for the
; task's context (certified by a learned stream over the `moving2d` synthetic skill) AND clear
; of a downstream obstacle (a test the learned model knows nothing about).
(define (domain synthetic-goodregion)
  (:requirements :strips)
  (:predicates (Task ?t) (Control ?t ?c) (GoodControl ?t ?c) (Clear ?t ?c) (Done ?t))
  (:action execute
    :parameters (?t ?c)
    :precondition (and (Task ?t) (GoodControl ?t ?c) (Clear ?t ?c))
    :effect (Done ?t)))
