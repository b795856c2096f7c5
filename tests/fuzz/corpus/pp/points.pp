<!DOCTYPE PickedPoints>
<PickedPoints>
 <DocumentData><DataFileName name="bar.obj"/></DocumentData>
 <point x="0.5" y="1" z="0" active="1" name="tip"/>
 <point x="1e3" y="-2" z="0" active="false" name="&amp;x&#65;"/>
</PickedPoints>
