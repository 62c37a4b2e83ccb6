; A symbolic kitchen whose motions depend on the state (PDDLStream kitchen style): one arm
; moves, picks and places kitchenware, fills a cup at a faucet, pours, scoops, dumps and
; stirs. The motion stream is a :fluents stream: it plans around the objects standing where
; the move happens, so a motion holds only in states where those objects stand there.
(define (domain kitchen-fluent)
  (:requirements :strips :typing :equality :negative-preconditions :derived-predicates
                 :existential-preconditions :universal-preconditions :conditional-effects)
  (:types ingredient)
  (:predicates
    ; static kinds
    (Graspable ?o) (Region ?r) (Faucet ?f) (Dispenses ?f ?m) (Container ?o) (Cup ?o)
    (Spoon ?o) (Stirrer ?o) (Pourable ?m) (Scoopable ?m) (Ingredient ?m)
    ; certified by streams
    (Pose ?o ?p) (Supported ?o ?p ?r) (Grasp ?o ?g) (Conf ?q) (Traj ?t)
    (Kin ?o ?p ?g ?q) (Motion ?q1 ?t ?q2) (FillConf ?f ?o ?g ?q)
    (SkillConf ?tool ?g ?target ?p ?q) (CFree ?o1 ?p1 ?o2 ?p2)
    ; fluents
    (AtPose ?o ?p) (AtGrasp ?o ?g) (AtConf ?q) (HandEmpty)
    (Contains ?o ?m) (Mixed ?o)
    ; derived
    (On ?o ?r) (Empty ?o) (UnsafePose ?o ?p))
  (:derived (On ?o ?r)
    (exists (?p) (and (Supported ?o ?p ?r) (AtPose ?o ?p))))
  (:derived (Empty ?o)
    (and (Container ?o) (forall (?m - ingredient) (not (Contains ?o ?m)))))
  (:derived (UnsafePose ?o ?p)
    (exists (?o2 ?p2) (and (Pose ?o ?p) (Pose ?o2 ?p2) (AtPose ?o2 ?p2) (not (= ?o ?o2))
                           (not (CFree ?o ?p ?o2 ?p2)))))
  (:action move
    :parameters (?q1 ?t ?q2)
    :precondition (and (Motion ?q1 ?t ?q2) (AtConf ?q1))
    :effect (and (AtConf ?q2) (not (AtConf ?q1))))
  (:action pick
    :parameters (?o ?p ?g ?q)
    :precondition (and (Kin ?o ?p ?g ?q) (AtPose ?o ?p) (HandEmpty) (AtConf ?q))
    :effect (and (AtGrasp ?o ?g) (not (AtPose ?o ?p)) (not (HandEmpty))))
  (:action place
    :parameters (?o ?p ?g ?q)
    :precondition (and (Kin ?o ?p ?g ?q) (AtGrasp ?o ?g) (AtConf ?q) (not (UnsafePose ?o ?p)))
    :effect (and (AtPose ?o ?p) (HandEmpty) (not (AtGrasp ?o ?g))))
  (:action fill
    :parameters (?f ?m ?c ?g ?q)
    :precondition (and (Dispenses ?f ?m) (FillConf ?f ?c ?g ?q) (AtGrasp ?c ?g) (AtConf ?q)
                       (Empty ?c))
    :effect (and (Contains ?c ?m)))
  (:action pour
    :parameters (?c ?m ?b ?p ?g ?q)
    :precondition (and (Pourable ?m) (SkillConf ?c ?g ?b ?p ?q) (AtGrasp ?c ?g)
                       (AtPose ?b ?p) (AtConf ?q) (Contains ?c ?m) (Cup ?b) (not (= ?c ?b)))
    :effect (and (Contains ?b ?m) (not (Contains ?c ?m)) (not (Mixed ?b))))
  (:action scoop
    :parameters (?s ?m ?b ?p ?g ?q)
    :precondition (and (Spoon ?s) (Scoopable ?m) (SkillConf ?s ?g ?b ?p ?q) (AtGrasp ?s ?g)
                       (AtPose ?b ?p) (AtConf ?q) (Contains ?b ?m) (Empty ?s))
    :effect (and (Contains ?s ?m)))
  ; Dumping empties the spoon of whatever it holds into the cup.
  (:action dump
    :parameters (?s ?c ?p ?g ?q)
    :precondition (and (Spoon ?s) (SkillConf ?s ?g ?c ?p ?q) (AtGrasp ?s ?g) (AtPose ?c ?p)
                       (AtConf ?q) (Cup ?c) (not (Empty ?s)))
    :effect (and (not (Mixed ?c))
                 (forall (?m - ingredient)
                   (when (Contains ?s ?m) (and (Contains ?c ?m) (not (Contains ?s ?m)))))))
  (:action stir
    :parameters (?s ?c ?p ?g ?q)
    :precondition (and (Stirrer ?s) (Cup ?c) (SkillConf ?s ?g ?c ?p ?q) (AtGrasp ?s ?g)
                       (AtPose ?c ?p) (AtConf ?q)
                       ; only a cup holding every ingredient is worth stirring
                       (forall (?m - ingredient) (Contains ?c ?m)))
    :effect (and (Mixed ?c))))
