; 2D pick-and-place with a free-flying gripper, for samplers that know nothing of other
; blocks (PDDLStream continuous_tamp style): collisions are ruled out only by the negated
; derived predicate UnsafePose over the test-cfree stream.
(define (domain tamp2d-uniform)
  (:requirements :strips :equality :negative-preconditions :derived-predicates :action-costs)
  (:predicates
    (Block ?b) (Region ?r) (Pose ?b ?p) (Grasp ?b ?g) (Conf ?q) (Traj ?t)
    (Kin ?b ?q ?p ?g) (Motion ?q1 ?t ?q2) (Contained ?b ?p ?r) (CFree ?b1 ?p1 ?b2 ?p2)
    (AtPose ?b ?p) (AtGrasp ?b ?g) (AtConf ?q) (HandEmpty) (CanMove)
    (In ?b ?r) (Holding ?b) (UnsafePose ?b ?p))
  (:functions (Distance ?q1 ?q2) (total-cost))
  (:derived (In ?b ?r)
    (exists (?p) (and (Contained ?b ?p ?r) (AtPose ?b ?p))))
  (:derived (Holding ?b)
    (exists (?g) (and (Grasp ?b ?g) (AtGrasp ?b ?g))))
  ; A pose is unsafe when it is not certified collision-free with another block's pose.
  (:derived (UnsafePose ?b ?p)
    (exists (?b2 ?p2) (and (Pose ?b ?p) (Pose ?b2 ?p2) (AtPose ?b2 ?p2) (not (= ?b ?b2))
                           (not (CFree ?b ?p ?b2 ?p2)))))
  (:action move
    :parameters (?q1 ?t ?q2)
    :precondition (and (Motion ?q1 ?t ?q2) (AtConf ?q1) (CanMove))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (not (CanMove))
                 (increase (total-cost) (Distance ?q1 ?q2))))
  (:action pick
    :parameters (?b ?p ?g ?q)
    :precondition (and (Kin ?b ?q ?p ?g) (AtPose ?b ?p) (HandEmpty) (AtConf ?q))
    :effect (and (AtGrasp ?b ?g) (CanMove) (not (AtPose ?b ?p)) (not (HandEmpty))
                 (increase (total-cost) 1)))
  (:action place
    :parameters (?b ?p ?g ?q)
    :precondition (and (Kin ?b ?q ?p ?g) (AtGrasp ?b ?g) (AtConf ?q)
                       (not (UnsafePose ?b ?p)))
    :effect (and (AtPose ?b ?p) (HandEmpty) (CanMove) (not (AtGrasp ?b ?g))
                 (increase (total-cost) 1))))
