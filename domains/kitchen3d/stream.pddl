(define (stream kitchen3d)
  ; Engineered: placements in a table region, grasps of an object.
  (:stream sample-placement
    :inputs (?o ?r)
    :domain (Stackable ?o ?r)
    :outputs (?p)
    :certified (and (Pose ?o ?p) (Contained ?o ?p ?r)))
  (:stream sample-grasp
    :inputs (?o)
    :domain (Graspable ?o)
    :outputs (?g)
    :certified (Grasp ?o ?g))
  ; Verified IK of arm ?r's pre-grasp and the Cartesian approach path into the grasp.
  (:stream inverse-kinematics
    :inputs (?r ?o ?p ?g)
    :domain (and (Arm ?r) (Pose ?o ?p) (Grasp ?o ?g) (InReach ?r ?o ?p))
    :outputs (?q ?a)
    :certified (and (Conf ?r ?q) (HoldConf ?r ?o ?g ?q) (Traj ?a) (Kin ?r ?o ?p ?g ?q ?a)))
  ; Fluent-free motions: RRT-Connect around the fixed scenery (movable objects: CFreeTraj).
  (:stream plan-free-motion
    :inputs (?r ?q1 ?q2)
    :domain (and (Conf ?r ?q1) (Conf ?r ?q2))
    :outputs (?t)
    :certified (and (Traj ?t) (FreeMotion ?r ?q1 ?t ?q2)))
  (:stream plan-holding-motion
    :inputs (?r ?o ?g ?q1 ?q2)
    :domain (and (HoldConf ?r ?o ?g ?q1) (HoldConf ?r ?o ?g ?q2))
    :outputs (?t)
    :certified (and (Traj ?t) (HoldingMotion ?r ?o ?g ?q1 ?t ?q2)))
  ; Learned GoodPour control, its cup path, and that path followed by the arm
  ; (follow-obj-path): the pour start conf and the arm path of the whole pour.
  (:stream sample-pour
    :inputs (?r ?k ?g ?c ?p)
    :domain (and (Arm ?r) (Pourable ?k) (Grasp ?k ?g) (Receptacle ?c) (Pose ?c ?p)
                 (InReach ?r ?c ?p))
    :outputs (?q ?a ?u)
    :certified (and (Conf ?r ?q) (HoldConf ?r ?k ?g ?q) (Traj ?a)
                    (PourKin ?r ?k ?g ?c ?p ?q ?a ?u)))
  ; Learned GoodScoop control, its spoon path in the bowl, followed by the arm: the start
  ; conf (spoon upright above the bowl), the end conf (spoonful lifted) and the arm path.
  (:stream sample-scoop
    :inputs (?r ?s ?g ?b ?p)
    :domain (and (Arm ?r) (Spoon ?s) (Grasp ?s ?g) (Scoopable ?b) (Pose ?b ?p))
    :outputs (?q1 ?q2 ?a ?u)
    :certified (and (Conf ?r ?q1) (Conf ?r ?q2) (HoldConf ?r ?s ?g ?q1) (HoldConf ?r ?s ?g ?q2)
                    (Traj ?a) (ScoopKin ?r ?s ?g ?b ?p ?q1 ?q2 ?a ?u)))
  ; Engineered: the spoon rolled over above a receptacle; the stirrer circling in it.
  (:stream sample-dump
    :inputs (?r ?s ?g ?c ?p)
    :domain (and (Arm ?r) (Spoon ?s) (Grasp ?s ?g) (Receptacle ?c) (Pose ?c ?p))
    :outputs (?q ?a)
    :certified (and (Conf ?r ?q) (HoldConf ?r ?s ?g ?q) (Traj ?a) (DumpKin ?r ?s ?g ?c ?p ?q ?a)))
  (:stream sample-stir
    :inputs (?r ?s ?g ?c ?p)
    :domain (and (Arm ?r) (Stirrer ?s) (Grasp ?s ?g) (Receptacle ?c) (Pose ?c ?p))
    :outputs (?q ?a)
    :certified (and (Conf ?r ?q) (HoldConf ?r ?s ?g ?q) (Traj ?a) (StirKin ?r ?s ?g ?c ?p ?q ?a)))
  ; Engineered: a straight-line push of ?o from ?p1 to ?p2 by arm ?r's empty hand.
  (:stream sample-push
    :inputs (?r ?o ?p1 ?p2)
    :domain (and (Arm ?r) (Pushable ?o) (Pose ?o ?p1) (Pose ?o ?p2) (InReach ?r ?o ?p1)
                 (InReach ?r ?o ?p2))
    :outputs (?q1 ?q2 ?a)
    :certified (and (Conf ?r ?q1) (Conf ?r ?q2) (Traj ?a) (PushKin ?r ?o ?p1 ?p2 ?q1 ?q2 ?a)))
  ; Eager, cheap: is ?o at ?p within arm ?r's reach (horizontal distance from its base)? A
  ; given pose out of an arm's reach then rules out that arm's picks, pushes and pours there
  ; before any search (in push_to_reach the planner otherwise kept trying arm r0's pushes of
  ; the far bowl and arm r1's picks of the far cup, and ground all their optimistic facts).
  (:stream test-reach
    :inputs (?r ?o ?p)
    :domain (and (Arm ?r) (Pose ?o ?p))
    :certified (InReach ?r ?o ?p))
  (:stream test-cfree
    :inputs (?o1 ?p1 ?o2 ?p2)
    :domain (and (Pose ?o1 ?p1) (Pose ?o2 ?p2))
    :certified (CFree ?o1 ?p1 ?o2 ?p2))
  (:stream test-cfree-traj
    :inputs (?t ?o2 ?p2)
    :domain (and (Traj ?t) (Pose ?o2 ?p2))
    :certified (CFreeTraj ?t ?o2 ?p2))
  (:function (Distance ?r ?q1 ?q2)
    (and (Conf ?r ?q1) (Conf ?r ?q2))))
