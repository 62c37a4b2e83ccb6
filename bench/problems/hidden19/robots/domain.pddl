; 2D pick-and-place with one or more robots on a line (PDDLStream continuous_tamp style),
; written for ltamp's hidden suite (issue #19). Each robot reaches only part of the table,
; blocks have their own widths, and fixed obstacles (blocks nobody can grasp) may stand in
; the regions. Collisions are ruled out only through the negated derived UnsafePose over the
; test-cfree stream; region membership of any pose is certified by the test-region stream.
(define (domain hidden-robots)
  (:requirements :strips :equality :negative-preconditions :derived-predicates :action-costs)
  (:predicates
    (Robot ?r) (Block ?b) (Movable ?b) (Region ?s) (Pose ?b ?p) (Grasp ?b ?g) (Conf ?r ?q)
    (Traj ?t) (Kin ?r ?b ?q ?p ?g) (Motion ?r ?q1 ?t ?q2) (Contained ?b ?p ?s)
    (CFree ?b1 ?p1 ?b2 ?p2)
    (AtPose ?b ?p) (AtGrasp ?r ?b ?g) (AtConf ?r ?q) (HandEmpty ?r) (CanMove ?r)
    (In ?b ?s) (Holding ?r ?b) (UnsafePose ?b ?p))
  (:functions (Distance ?r ?q1 ?q2) (total-cost))
  (:derived (In ?b ?s)
    (exists (?p) (and (Contained ?b ?p ?s) (AtPose ?b ?p))))
  (:derived (Holding ?r ?b)
    (exists (?g) (and (Robot ?r) (Grasp ?b ?g) (AtGrasp ?r ?b ?g))))
  (:derived (UnsafePose ?b ?p)
    (exists (?b2 ?p2) (and (Pose ?b ?p) (Pose ?b2 ?p2) (AtPose ?b2 ?p2) (not (= ?b ?b2))
                           (not (CFree ?b ?p ?b2 ?p2)))))
  (:action move
    :parameters (?r ?q1 ?t ?q2)
    :precondition (and (Motion ?r ?q1 ?t ?q2) (AtConf ?r ?q1) (CanMove ?r))
    :effect (and (AtConf ?r ?q2) (not (AtConf ?r ?q1)) (not (CanMove ?r))
                 (increase (total-cost) (Distance ?r ?q1 ?q2))))
  (:action pick
    :parameters (?r ?b ?p ?g ?q)
    :precondition (and (Kin ?r ?b ?q ?p ?g) (AtPose ?b ?p) (HandEmpty ?r) (AtConf ?r ?q))
    :effect (and (AtGrasp ?r ?b ?g) (CanMove ?r) (not (AtPose ?b ?p)) (not (HandEmpty ?r))
                 (increase (total-cost) 1)))
  (:action place
    :parameters (?r ?b ?p ?g ?q)
    :precondition (and (Kin ?r ?b ?q ?p ?g) (AtGrasp ?r ?b ?g) (AtConf ?r ?q)
                       (not (UnsafePose ?b ?p)))
    :effect (and (AtPose ?b ?p) (HandEmpty ?r) (CanMove ?r) (not (AtGrasp ?r ?b ?g))
                 (increase (total-cost) 1))))
