(define (stream kitchen2d)
  ; Engineered: the object's spots in a region (home on the table, coaster, faucet).
  ; Confs: (Conf ?q) the hand may be empty there; (HoldConf ?o ?g ?q) it may hold ?o by ?g.
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
  ; Conf above the object's spot and the straight approach down to the grasp.
  (:stream inverse-kinematics
    :inputs (?o ?p ?g)
    :domain (and (Pose ?o ?p) (Grasp ?o ?g))
    :outputs (?q ?a)
    :certified (and (Conf ?q) (HoldConf ?o ?g ?q) (Kin ?o ?p ?g ?q ?a)))
  ; OMPL RRT-Connect for the gripper (alone or carrying ?o) around the reserved columns.
  (:stream plan-free-motion
    :inputs (?q1 ?q2)
    :domain (and (Conf ?q1) (Conf ?q2))
    :outputs (?t)
    :certified (and (Traj ?t) (FreeMotion ?q1 ?t ?q2)))
  (:stream plan-holding-motion
    :inputs (?o ?g ?q1 ?q2)
    :domain (and (HoldConf ?o ?g ?q1) (HoldConf ?o ?g ?q2))
    :outputs (?t)
    :certified (and (Traj ?t) (HoldingMotion ?o ?g ?q1 ?t ?q2)))
  ; Learned (GP level set, most confident control first): GoodPour and GoodScoop.
  ; Pours, dumps and stirs happen where drinks are prepared: a (Workspace ?r) region.
  (:stream sample-pour
    :inputs (?k ?c ?p ?r)
    :domain (and (Pitcher ?k) (Cup ?c) (Contained ?c ?p ?r) (Workspace ?r))
    :outputs (?g ?q ?a ?u)
    :certified (and (Grasp ?k ?g) (HoldConf ?k ?g ?q) (PourKin ?k ?g ?c ?p ?q ?a ?u)))
  (:stream sample-scoop
    :inputs (?s ?b ?p)
    :domain (and (Spoon ?s) (Bowl ?b) (Pose ?b ?p))
    :outputs (?g ?q ?a ?u)
    :certified (and (Grasp ?s ?g) (HoldConf ?s ?g ?q) (ScoopKin ?s ?g ?b ?p ?q ?a ?u)))
  ; Learned GoodPush: push block ?o at ?p off the table over edge ?e; ?q is the conf above
  ; the pusher's start, ?a the descent and the push, ?u the push skill's control.
  (:stream sample-push
    :inputs (?o ?p ?e)
    :domain (and (Block ?o) (Pose ?o ?p) (Edge ?e))
    :outputs (?q ?a ?u)
    :certified (and (Conf ?q) (PushKin ?o ?p ?e ?q ?a ?u)))
  ; Engineered dump and stir over a cup.
  (:stream sample-dump
    :inputs (?s ?g ?c ?p ?r)
    :domain (and (Spoon ?s) (Grasp ?s ?g) (Cup ?c) (Contained ?c ?p ?r) (Workspace ?r))
    :outputs (?q ?a ?u)
    :certified (and (HoldConf ?s ?g ?q) (DumpKin ?s ?g ?c ?p ?q ?a ?u)))
  (:stream sample-stir
    :inputs (?s ?g ?c ?p ?r)
    :domain (and (Stirrer ?s) (Grasp ?s ?g) (Cup ?c) (Contained ?c ?p ?r) (Workspace ?r))
    :outputs (?q ?a ?u)
    :certified (and (HoldConf ?s ?g ?q) (StirKin ?s ?g ?c ?p ?q ?a ?u)))
  (:stream test-cfree
    :inputs (?o1 ?p1 ?o2 ?p2)
    :domain (and (Pose ?o1 ?p1) (Pose ?o2 ?p2))
    :certified (CFree ?o1 ?p1 ?o2 ?p2))
  (:function (Distance ?q1 ?q2)
    (and (Conf ?q1) (Conf ?q2)))
  (:function (HoldDistance ?o ?g ?q1 ?q2)
    (and (HoldConf ?o ?g ?q1) (HoldConf ?o ?g ?q2))))
