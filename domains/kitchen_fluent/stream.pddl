(define (stream kitchen-fluent)
  (:stream sample-pose
    :inputs (?o ?r)
    :domain (and (Graspable ?o) (Region ?r))
    :outputs (?p)
    :certified (and (Pose ?o ?p) (Supported ?o ?p ?r)))
  (:stream sample-grasp
    :inputs (?o)
    :domain (Graspable ?o)
    :outputs (?g)
    :certified (Grasp ?o ?g))
  (:stream inverse-kinematics
    :inputs (?o ?p ?g)
    :domain (and (Pose ?o ?p) (Grasp ?o ?g))
    :outputs (?q)
    :certified (and (Conf ?q) (Kin ?o ?p ?g ?q)))
  (:stream fill-conf
    :inputs (?f ?c ?g)
    :domain (and (Faucet ?f) (Cup ?c) (Grasp ?c ?g))
    :outputs (?q)
    :certified (and (Conf ?q) (FillConf ?f ?c ?g ?q)))
  (:stream skill-conf
    :inputs (?tool ?g ?target ?p)
    :domain (and (Grasp ?tool ?g) (Container ?target) (Pose ?target ?p))
    :outputs (?q)
    :certified (and (Conf ?q) (SkillConf ?tool ?g ?target ?p ?q)))
  ; Planned in the state where the move happens: the poses of the objects standing and the
  ; object held, if any.
  (:stream plan-motion
    :inputs (?q1 ?q2)
    :domain (and (Conf ?q1) (Conf ?q2))
    :fluents (AtPose AtGrasp)
    :outputs (?t)
    :certified (and (Traj ?t) (Motion ?q1 ?t ?q2)))
  (:stream test-cfree
    :inputs (?o1 ?p1 ?o2 ?p2)
    :domain (and (Pose ?o1 ?p1) (Pose ?o2 ?p2))
    :certified (CFree ?o1 ?p1 ?o2 ?p2)))
